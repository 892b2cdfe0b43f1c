"""MkDocs hooks of the documentation site (``mkdocs.yml``: ``hooks``): the study-file and mechanism-file
references are generated from the loaders' key tables at every build (``scripts/docs_reference.py``), so
they cannot drift; a key the loaders accept with no description stops the build."""

from __future__ import annotations

import sys
from pathlib import Path

from mkdocs.exceptions import PluginError
from mkdocs.structure.files import File

sys.path.insert(0, str(Path(__file__).resolve().parent))
import docs_reference  # noqa: E402


def on_files(files, config):
    try:
        generated = docs_reference.pages()
    except RuntimeError as exc:
        raise PluginError(str(exc)) from None
    for path, text in generated.items():
        files.append(File.generated(config, path, content=text))
    return files
