"""The web layer: a Flask app over an :class:`~explorer.edit._session.EditSession`, and the server that runs it.

Routes (JSON in and out; a :class:`~explorer.errors.UserError` is ``400 {"error": one line}``, anything
else ``500 {"error": ...}``: the page shows either, nothing crashes)::

    GET  /                  the page (static/index.html; static/edit.js, static/edit.css)
    GET  /api/session       the reference design and its solve, the metric table, the settings
    GET  /api/design        the current design, as the mechanism file's data           (contract)
    PUT  /api/design        make a design current (undo, redo, reset, a shared link)
    POST /api/solve         a design -> foot path, status, walker metrics = explorer.simulate (contract)
    POST /api/drag          {design, angle, joint, to, config} -> the dragged design and its solve
    POST /api/edit          {design, parameters: {name: value}} -> the design and its solve
    POST /api/reset         the reference design again
    POST /api/yield         {design, tolerance, unit, copies} -> the yield
    POST /api/toml          {design} -> the mechanism file's text
    POST /api/save          {design, path, format, force} -> the files written (409 if one exists)
    POST /api/mechanism     {name} -> open a built-in or a mechanism file
    POST /api/study         {path} -> open a results file;  GET /api/study?x=&y= its ranking and scatter
    POST /api/variant       {variant} -> load a variant of the open results file

Safety: the server listens on 127.0.0.1 unless told otherwise; it answers only requests addressed to the
host and port it listens on (a page elsewhere cannot reach it through DNS rebinding), takes POST and
PUT bodies only as ``application/json`` (which a page on another origin cannot send without the CORS
preflight this server never grants) and only from its own origin, and never runs what it receives:
a design is data for the mechanism loader's validation.
"""

from __future__ import annotations

import socket
import sys
import threading
import time
from importlib import resources

from ..errors import UserError

#: Largest request body, bytes.
MAX_BODY = 4 << 20
#: Default port; when it is taken (and --port was not given) a free one is used.
DEFAULT_PORT = 8765


def make_app(session, allowed_hosts=None):
    """The Flask app serving ``session``; ``allowed_hosts``: the Host header values it answers (None:
    any, for a test client)."""
    from .._extras import require
    require("flask", "explorer edit")
    from flask import Flask, Response, jsonify, request

    app = Flask(__name__, static_folder=None)
    app.config["MAX_CONTENT_LENGTH"] = MAX_BODY
    app.json.sort_keys = False
    static = resources.files("explorer.edit") / "static"
    types = {".html": "text/html; charset=utf-8", ".js": "text/javascript; charset=utf-8",
             ".css": "text/css; charset=utf-8", ".txt": "text/plain; charset=utf-8"}

    def file_response(name: str):
        item = static / name
        if "/" in name or name.startswith(".") or not item.is_file():
            return jsonify({"error": f"no such file: {name}"}), 404
        suffix = name[name.rfind("."):]
        resp = Response(item.read_bytes(), mimetype=types.get(suffix, "application/octet-stream"))
        resp.headers["Cache-Control"] = "no-store"
        return resp

    @app.before_request
    def guard():
        if allowed_hosts is not None and request.host not in allowed_hosts:
            return jsonify({"error": f"this server answers requests to {', '.join(sorted(allowed_hosts))} only"}), 403
        if request.method in ("POST", "PUT"):
            origin = request.headers.get("Origin")
            if origin is not None and origin != f"{request.scheme}://{request.host}":
                return jsonify({"error": "requests from another origin are refused"}), 403
            if request.mimetype != "application/json":
                return jsonify({"error": "expected a JSON body (Content-Type: application/json)"}), 415
        return None

    @app.after_request
    def headers(resp):
        resp.headers["X-Content-Type-Options"] = "nosniff"
        resp.headers["Content-Security-Policy"] = ("default-src 'self'; img-src 'self' data:; "
                                                   "style-src 'self'; script-src 'self'; frame-ancestors 'none'")
        resp.headers["Referrer-Policy"] = "no-referrer"
        return resp

    def body() -> dict:
        import json

        try:  # NaN and Infinity are read as such: the design's validation names the key that holds one
            return json.loads(request.get_data(cache=False))
        except (ValueError, RecursionError) as exc:
            raise UserError(f"the request is not valid JSON ({' '.join(str(exc).split())[:200]})") from None

    def design_of(data: dict):
        """The design of a request body: {"design": {...}, ...}."""
        if not isinstance(data, dict) or "design" not in data:
            raise UserError("expected {\"design\": {...}, ...}")
        return data["design"]

    @app.errorhandler(UserError)
    def user_error(exc):
        return jsonify({"error": " ".join(str(exc).split("\n"))}), 400

    @app.errorhandler(413)
    def too_large(exc):
        return jsonify({"error": f"request too large (at most {MAX_BODY >> 20} MB)"}), 413

    @app.errorhandler(Exception)
    def failure(exc):
        from werkzeug.exceptions import HTTPException
        if isinstance(exc, HTTPException):
            return jsonify({"error": f"{exc.code} {exc.name}"}), exc.code
        import traceback
        traceback.print_exc(file=sys.stderr)
        return jsonify({"error": f"internal error ({type(exc).__name__}: {' '.join(str(exc).split())[:300]}); "
                                 f"the server's log has the traceback"}), 500

    @app.get("/")
    def index():
        return file_response("index.html")

    @app.get("/static/<name>")
    def static_file(name):
        return file_response(name)

    @app.get("/api/session")
    def info():
        return jsonify(session.info())

    @app.get("/api/design")
    def get_design():
        from ._design import design_data
        return jsonify(design_data(session.current))

    @app.put("/api/design")
    def put_design():
        data = body()
        return jsonify(session.set_design(data["design"] if isinstance(data, dict) and "design" in data
                                          and "links" not in data else data))

    @app.post("/api/solve")
    def solve():
        data = body()
        if isinstance(data, dict) and "design" in data and "links" not in data:  # {"design": ..., "steps": n}
            return jsonify(session.solve(data["design"], data.get("steps")))
        return jsonify(session.solve(data))

    @app.post("/api/drag")
    def drag():
        data = body()
        return jsonify(session.drag(design_of(data), data.get("angle", 0.0), data.get("joint"), data.get("to"),
                                    data.get("config")))

    @app.post("/api/edit")
    def edit():
        data = body()
        return jsonify(session.edit(design_of(data), data.get("parameters")))

    @app.post("/api/reset")
    def reset():
        return jsonify(session.reset())

    @app.post("/api/yield")
    def yield_():
        data = body()
        return jsonify(session.design_yield(design_of(data), data.get("tolerance"), data.get("unit", "%"),
                                            data.get("copies", 256)))

    @app.post("/api/toml")
    def toml():
        return jsonify(session.toml(design_of(body())))

    @app.post("/api/save")
    def save():
        data = body()
        try:
            return jsonify(session.save(design_of(data), data.get("path"), data.get("format", "toml"),
                                        data.get("force", False), data.get("check", False)))
        except UserError as exc:
            text = " ".join(str(exc).split("\n"))
            if "file exists" in text:  # the page asks before it sends force
                return jsonify({"error": text, "exists": True}), 409
            raise

    @app.post("/api/mechanism")
    def mechanism():
        return jsonify(session.open_mechanism(body().get("name")))

    @app.post("/api/study")
    def open_study():
        return jsonify(session.open_study(body().get("path")))

    @app.get("/api/study")
    def study():
        return jsonify(session.study_summary(request.args.get("x"), request.args.get("y")))

    @app.post("/api/variant")
    def variant():
        return jsonify(session.load_variant(body().get("variant")))

    return app


def free_port(host: str, port: int) -> bool:
    """Whether ``port`` on ``host`` can be listened on."""
    with socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True


class Server:
    """The app on a threaded WSGI server (werkzeug's, HTTP/1.1 keep-alive, requests not logged).

    ``Server(session, host, port)`` binds (port 0: any free one); :attr:`url`; :meth:`start` serves on a
    background thread, :meth:`serve` in this one until :meth:`stop` or Ctrl-C."""

    def __init__(self, session, host: str = "127.0.0.1", port: int = 0):
        from werkzeug.serving import WSGIRequestHandler, make_server

        class Quiet(WSGIRequestHandler):
            protocol_version = "HTTP/1.1"  # keep-alive: one connection for a whole drag
            disable_nagle_algorithm = True  # headers and body go out at once (no delayed-ACK stall of ~40 ms)

            def log_request(self, *args, **kwargs):
                pass

        self.host = host
        self._httpd = None
        try:
            httpd = make_server(host, port, None, threaded=True, request_handler=Quiet)
        except OSError as exc:
            raise UserError(f"cannot listen on {host}:{port}: {exc.strerror or exc}") from None
        self.port = int(httpd.server_port)
        shown = f"[{host}]" if ":" in host else host
        hosts = {f"{shown}:{self.port}"}
        if host in ("127.0.0.1", "::1", "localhost"):
            hosts |= {f"127.0.0.1:{self.port}", f"localhost:{self.port}", f"[::1]:{self.port}"}
        elif host in ("0.0.0.0", "::", ""):
            hosts = None  # told to listen everywhere: any name of this machine
        httpd.app = make_app(session, hosts)
        self._httpd = httpd
        self.url = f"http://{'127.0.0.1' if host in ('0.0.0.0', '::', '') else shown}:{self.port}/"
        self._thread = None

    def start(self) -> "Server":
        self._thread = threading.Thread(target=self._httpd.serve_forever, name="explorer-edit", daemon=True)
        self._thread.start()
        return self

    def serve(self) -> None:
        self._httpd.serve_forever()

    def stop(self) -> None:
        if self._httpd is not None:
            self._httpd.shutdown()
            self._httpd.server_close()
            self._httpd = None


def serve(session, host: str = "127.0.0.1", port: int | None = None, open_browser: bool = True,
          out=sys.stdout) -> None:
    """Serve ``session`` until Ctrl-C: bind (``port`` None: :data:`DEFAULT_PORT`, else a free port when
    it is taken), print the address, open the browser on it (``open_browser``)."""
    if port is None:
        port = DEFAULT_PORT if free_port(host, DEFAULT_PORT) else 0
    server = Server(session, host, port)
    print(f"explorer edit: {session.reference_label} at {server.url} (Ctrl-C to stop)", file=out, flush=True)
    if host not in ("127.0.0.1", "::1", "localhost"):
        print(f"explorer edit: listening on {host}: anyone who can reach this machine on port {server.port} can "
              f"use the editor and save files as you", file=out, flush=True)
    if open_browser:
        import webbrowser
        threading.Thread(target=lambda: (time.sleep(0.2), webbrowser.open(server.url)), daemon=True).start()
    try:
        server.serve()
    finally:
        server.stop()
