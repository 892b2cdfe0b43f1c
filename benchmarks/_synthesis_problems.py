"""The classic four-bar path-generation problems of the synthesis literature, as data, and the map
from the literature's parametrisation of a four-bar to an explorer mechanism.

The parametrisation (Cabrera, Simon & Prado 2002, and the papers that reuse their problems)
----------------------------------------------------------------------------------------------
r1 ground link, r2 crank (input link), r3 coupler, r4 rocker (output link); rcx, rcy the coupler point
in the coupler's own frame (origin at the crank pin A, x axis along the coupler A → B); θ0 the angle of
the ground link (crank pivot → rocker pivot) to the x axis; x0, y0 the crank pivot. The crank angle
θ2 of a precision point is measured from the ground link, so the crank's absolute angle is θ0 + θ2:
explorer's crank angle (counter-clockwise from +x) is θ = θ0 + θ2, i.e. a timed target in this
parametrisation is matched with ``path_error(..., angles=θ2, angle_offset=θ0)``.

    crank pivot  O2 = (x0, y0)                  rocker pivot  O4 = O2 + r1·(cos θ0, sin θ0)
    crank pin    A  = O2 + r2·(cos(θ0+θ2), sin(θ0+θ2))
    rocker pin   B  : |B − A| = r3, |B − O4| = r4, on the side ``branch`` of the line A → O4
    coupler point C = A + R(angle of A → B)·(rcx, rcy)

``branch`` = +1 puts B to the left of the directed line A → O4 (counter-clockwise side), −1 to the
right. The papers pick one of the two assembly configurations by a sign in a closed-form solution;
which geometric side that is has not been checked against their text here, so both are offered.

What was verified, and how
--------------------------
The sources were looked up with the project's stored-web search (corpora "pages" and "docs"), which
returns the opening of each stored page only:

* Cabrera, J.A., Simon, A., Prado, M., "Optimal synthesis of mechanisms with genetic algorithms",
  Mechanism and Machine Theory 37 (2002) 1165–1177 (University of Málaga; received 9 October 2001,
  accepted 10 April 2002): title, authors, journal, volume, pages and abstract VERIFIED on the opening
  page of a stored copy (https://www.scribd.com/document/574145232/Cabrera-2002).
* Kunjur, A., Krishnamurty, S., "Genetic algorithms in mechanism synthesis": a stored copy of the
  paper's abstract on the authors' laboratory site (http://www.ecs.umass.edu/mie/labs/mda/mechanism/
  papers/genetic.html) was found (a GA with a modified crossover and linear-normalisation selection,
  "illustrative examples"); the journal (Journal of Applied Mechanisms and Robotics 4(2), 1997,
  pp. 18–24) is NOT verified.
* Sleesongsom, S., Bureerat, S., "Optimal synthesis of four-bar linkage path generation through
  evolutionary computation with a novel constraint handling technique", Computational Intelligence and
  Neuroscience 2018, 5462563 (open access, PMC6236668): VERIFIED to reuse "three traditional path
  generation test problems"; which ones was not readable.

The bodies of these three papers (problem tables, variable limits, population sizes, generations,
errors reached) were NOT reachable: the stored copies (scribd, hindawi.com, pmc.ncbi.nlm.nih.gov
PMC6236668, and later restatements such as Yao et al., Mech. Sci. 13 (2022) 79-87, Winyangkul et al.,
Biomimetics 11 (2026) 160, Appl. Sci. 12 (2022) 7368) are searchable by their opening only. A second
look-up (stored web pages, documentation, public code by meaning and by exact string) found two
further kinds of source:

* A later paper restating the vertical line: "Dynamic Ant Search" for four-bar path generation,
  Proceedings of the ASME 2019 International Mechanical Engineering Congress and Exposition
  (IMECE2019, Salt Lake City), paper IMECE2019-10262, read from the copy of the PDF kept in
  https://github.com/OmarJItani/Mechanism-Synthesis-Using-Ant-Colony-Optimization (file
  IMECE2019-10262.pdf; its text pulled out of the PDF here, so table cells run together and Greek
  symbols are lost). Its case study II: "the synthesis problem of 6 target points arranged in a
  vertical straight line without prescribed timing"; Table 3: "x id 20 20 20 20 20 20 / y id 20 25 30
  35 40 45" -> the six points below are VERIFIED as restated there. Table 4 ("Parameter g d c f l x0
  y0 ... Lower Limit 5 5 5 5 0 -60 -60 ... Upper Limit 60 60 60 60 85 60 60", two angle columns
  unreadable): as far as the run-together cells can be read, ground, crank, coupler and rocker lengths
  in [5, 60] and the crank pivot x0, y0 in [-60, 60], in that paper's own parametrisation (coupler
  point by a length l in [0, 85] and an angle, not rcx, rcy). It compares with the DE of Mishra,
  Naskar & Acharya (2012) and the ICA of Ebrahimi & Payvandy (MMT 85, 2015), cites neither Kunjur nor
  Cabrera, and states no budget for its peers; its errors (Table 5: DE 0.0151, ICA 2.00E-03, its own
  4.02E-05) are of a normalised error (its eq. 2), not the sum of squares used here.
* Public code (not a published source; corroboration only): jmejia8/eca-four-bar-mechanisms,
  ``tools.jl`` (commit 17e8869; "part of this code was taken from MATLAB code of Eric Valentin,
  CIDETEC 2018") holds both problems: case 1 the six points (20, 20) ... (20, 45) with limits r1..r4
  in [0, 60], rcx, rcy, x0, y0 in [-60, 60], θ0 and the six θ2 in [0, 2π]; case 2 the five points
  "3 3; 2.759 3.363; 2.372 3.663; 1.890 3.862; 1.355 3.943" at θ2 = π/6, π/4, π/3, 10π/24, π/2. A MATLAB
  objective in public code found by exact-string search (repository not named by the search tool;
  "Caso de estudio 2: seguimiento de una trayectoria no alineada, con sincronización previa") has the
  same points and angles (2π/12 ... 6π/12). Both FIX θ0 = 0, x0 = 0, y0 = 0 in case 2 and optimise
  only r1..r4, rcx, rcy (the Julia file within r in [0, 50], rcx, rcy in [-50, 50]), and both require
  r1 + r2 ≤ r3 + r4, r2 ≤ r3, r3 ≤ r4, r4 ≤ r1. Whether Cabrera 2002 fixes θ0, x0, y0 in that case is
  NOT verified; :data:`TIMED_FIVE` keeps them free. Checked here: with θ0 = x0 = y0 = 0 least squares
  reaches a four-bar through the five points at their angles with sum of squares 7.42e-7 (r1 3.670,
  r2 1.998, r3 3.996, r4 2.705, rcx 1.672, rcy 1.680, branch +1, a Grashof crank-rocker inside the limits
  below; it breaks the code's r3 ≤ r4), so the data fit that reading too.

Therefore:

* the six points on x = 20: VERIFIED as restated by IMECE2019-10262 (a later paper), not against
  Kunjur & Krishnamurty or Cabrera 2002 themselves;
* the five timed points and their crank angles: NOT verified against a paper; they match two public
  code restatements exactly, and a four-bar passes through all five at their angles to within the
  3-decimal rounding of the data (see ``TIMED_FIVE.note``), so a best error of (nearly) 0 is
  attainable;
* the variable limits: the vertical line's link limits [5, 60] and pivot limits [-60, 60] are
  corroborated by IMECE2019-10262 Table 4 (its parametrisation); rcx, rcy and θ0 limits, and all of
  the timed problem's limits, are NOT verified;
* the budgets (population × generations or evaluations) of Kunjur 1997, Cabrera 2002 and the papers
  that reuse them were found in no readable source and stay None: quote them only after reading the
  papers' text.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

#: The design variables of the parametrisation, in order.
VARIABLES = ("r1", "r2", "r3", "r4", "rcx", "rcy", "theta0", "x0", "y0")


@dataclass(frozen=True)
class SynthesisProblem:
    """One path-generation problem.

    name : short id.
    source : the paper(s), as cited.
    points : ((x, y), ...) the precision points, in the source's units.
    angles : crank angles θ2 (radians, from the ground link) of the points, or None (no prescribed timing).
    bounds : {variable: (low, high)} for the variables of :data:`VARIABLES` (θ0 in radians); a variable
        the source fixes has low == high.
    budget : the source's evaluation budget as text ("population × generations"), or None where not
        verified.
    evaluations : the same as a number of objective evaluations, or None.
    best_error : the best known value of the source's objective (the sum of squared distances to the
        precision points), model units squared; 0 where an exact solution exists.
    verified : which of the fields above were checked against a published source.
    note : anything else a reader needs.
    phase : the timed angles are θ2_i = φ + angles[i] with the start angle φ a design variable in [0, 2π]
        (the closed curve timed at 20° steps), not fixed.
    published : the best value the literature publishes, with its budget, as text.

    A problem without timing has one more design variable per point, its crank angle θ2_i (the
    "untimed" formulation), in [0, 2π]; :attr:`n_variables` counts them.
    """

    name: str
    source: str
    points: tuple[tuple[float, float], ...]
    angles: tuple[float, ...] | None
    bounds: dict
    budget: str | None
    evaluations: int | None
    best_error: float
    verified: dict = field(default_factory=dict)
    note: str = ""
    phase: bool = False
    published: str = ""

    @property
    def timed(self) -> bool:
        return self.angles is not None

    @property
    def free(self) -> tuple:
        """The variables of :data:`VARIABLES` the problem searches (those whose bounds differ)."""
        return tuple(v for v in VARIABLES if self.bounds[v][0] != self.bounds[v][1])

    @property
    def n_variables(self) -> int:
        """Design variables as the literature counts them: the free ones, φ, one angle per point untimed."""
        return len(self.free) + int(self.phase) + (0 if self.timed else len(self.points))

    def target_spec(self, **extra) -> dict:
        """The problem as a study file's target table (:func:`explorer.gait._path.load_target`):
        angles in degrees. The timed angles are θ2, from the ground link: with θ0 free, match them with
        ``angle_offset = θ0``."""
        spec = {"points": [list(p) for p in self.points]}
        if self.angles is not None:
            spec["angles_deg"] = [math.degrees(a) for a in self.angles]
            spec["match"] = "timed"
        else:
            spec["match"] = "closest"
        spec.update(extra)
        return spec


VERTICAL_LINE = SynthesisProblem(
    name="vertical-line",
    source=("Kunjur & Krishnamurty, 'Genetic algorithms in mechanism synthesis', J. Applied Mechanisms "
            "and Robotics 4(2) 18-24 (1997); Cabrera, Simon & Prado, 'Optimal synthesis of mechanisms with "
            "genetic algorithms', Mechanism and Machine Theory 37 (2002) 1165-1177, case 1"),
    points=((20.0, 20.0), (20.0, 25.0), (20.0, 30.0), (20.0, 35.0), (20.0, 40.0), (20.0, 45.0)),
    angles=None,
    bounds={"r1": (5.0, 60.0), "r2": (5.0, 60.0), "r3": (5.0, 60.0), "r4": (5.0, 60.0),
            "rcx": (-60.0, 60.0), "rcy": (-60.0, 60.0), "theta0": (0.0, 2.0 * math.pi),
            "x0": (-60.0, 60.0), "y0": (-60.0, 60.0)},
    budget=None,
    evaluations=None,
    best_error=0.0,
    verified={"source": "Cabrera 2002 bibliographic data and abstract; Kunjur & Krishnamurty abstract only",
              "points": "as restated by a later paper (IMECE2019-10262, case study II, Table 3), not "
                        "against Kunjur 1997 or Cabrera 2002",
              "angles": "not applicable (no prescribed timing)",
              "bounds": "partly: r1..r4 in [5, 60] and x0, y0 in [-60, 60] match IMECE2019-10262 Table 4 "
                        "(its own parametrisation); rcx, rcy, θ0 not verified",
              "budget": False,
              "best_error": "0 by counting: without timing the six crank angles are free too (15 unknowns, "
                            "12 equations), and the issue states it"},
    note=("Without prescribed timing the source treats the six crank angles θ2_i as design variables "
          "(within [0, 2π], in increasing order); explorer's 'closest' matching (each point against the "
          "closest point of the whole cycle) finds them itself, with no order imposed. The source "
          "requires a crank that turns fully (Grashof, crank shortest)."),
)

TIMED_FIVE = SynthesisProblem(
    name="timed-five",
    source=("Cabrera, Simon & Prado, 'Optimal synthesis of mechanisms with genetic algorithms', Mechanism "
            "and Machine Theory 37 (2002) 1165-1177, case 2 (path generation with prescribed timing)"),
    points=((3.0, 3.0), (2.759, 3.363), (2.372, 3.663), (1.890, 3.862), (1.355, 3.943)),
    angles=(math.pi / 6, math.pi / 4, math.pi / 3, 5 * math.pi / 12, math.pi / 2),
    bounds={"r1": (0.0, 5.0), "r2": (0.0, 5.0), "r3": (0.0, 5.0), "r4": (0.0, 5.0),
            "rcx": (-5.0, 5.0), "rcy": (-5.0, 5.0), "theta0": (0.0, 2.0 * math.pi),
            "x0": (-5.0, 5.0), "y0": (-5.0, 5.0)},
    budget=None,
    evaluations=None,
    best_error=0.0,
    verified={"source": "Cabrera 2002 bibliographic data and abstract (the case number is not verified)",
              "points": "not against the paper; match two public code restatements; consistent with a "
                        "four-bar to the data's rounding (below)",
              "angles": "not against the paper; match the same code restatements; consistent with the "
                        "points (below)",
              "bounds": "not verified; the code restatements fix θ0 = x0 = y0 = 0 (see the module docstring)",
              "budget": False,
              "best_error": "≈ 0: a four-bar passes through the five points at their angles to the 3-decimal "
                            "rounding of the data (sum of squares 2.71e-7, found here)"},
    note=("Crank angles θ2 are from the ground link: explorer's crank angle is θ0 + θ2 (path_error's "
          "angle_offset = θ0). Consistency check made for this file: least squares over the nine variables "
          "from random starts reached a four-bar through the five points at their crank angles with a "
          "residual at the level of the data's 3-decimal rounding; see CONSISTENT_TIMED_FIVE."),
)

_NGUYEN_VAN = ("Nguyen-Van, S., et al., a hybrid DE/Jaya method, Symmetry 14(2) 381 (2022); its code and the 50 "
               "runs it stores: github.com/sy-nguyen-van/DE_Jaya_Synthesis_Four_Bar_Mechanisms (commit a18dcd4)")

#: The 18 points of the closed curve, as written in Case3/Objf3.m of the Nguyen-Van repository
#: ("CD=[0.5, 1.1; 0.4, 1.1; 0.3, 1.1; 0.2, 1.0; 0.1, 0.9; 0.05, 0.75; 0.02, 0.6; 0.0, 0.5; 0.0, 0.4;
#: 0.03, 0.3; 0.1, 0.25; 0.15, 0.2; 0.2, 0.3; 0.3, 0.4; 0.4, 0.5; 0.5, 0.7; 0.6, 0.9; 0.6, 1.0]").
CLOSED_POINTS = ((0.5, 1.1), (0.4, 1.1), (0.3, 1.1), (0.2, 1.0), (0.1, 0.9), (0.05, 0.75), (0.02, 0.6), (0.0, 0.5),
                 (0.0, 0.4), (0.03, 0.3), (0.1, 0.25), (0.15, 0.2), (0.2, 0.3), (0.3, 0.4), (0.4, 0.5), (0.5, 0.7),
                 (0.6, 0.9), (0.6, 1.0))
_CLOSED_BOUNDS = {"r1": (0.0, 50.0), "r2": (0.0, 50.0), "r3": (0.0, 50.0), "r4": (0.0, 50.0),
                  "rcx": (-50.0, 50.0), "rcy": (-50.0, 50.0), "theta0": (0.0, 2.0 * math.pi),
                  "x0": (-50.0, 50.0), "y0": (-50.0, 50.0)}

TIMED_FIVE_ORIGIN = SynthesisProblem(
    name="timed-five",
    source=_NGUYEN_VAN + ", Case2 (Objf2.m, Mechanisms.m); the problem of Cabrera, Simon & Prado, MMT 37 (2002)",
    points=TIMED_FIVE.points,
    angles=TIMED_FIVE.angles,
    bounds={"r1": (0.0, 50.0), "r2": (0.0, 50.0), "r3": (0.0, 50.0), "r4": (0.0, 50.0),
            "rcx": (-50.0, 50.0), "rcy": (-50.0, 50.0), "theta0": (0.0, 0.0), "x0": (0.0, 0.0), "y0": (0.0, 0.0)},
    budget="5,000 evaluations (the issue's table)",
    evaluations=5000,
    best_error=7.4158e-7,
    verified={"points": "Case2/Objf2.m: Cdx=[3, 2.759, 2.372, 1.890, 1.355]; Cdy=[3, 3.363, 3.663, 3.862, 3.943]",
              "angles": "Case2/Objf2.m: Teta2=[pi/6;pi/4;pi/3;5*pi/12;pi/2]",
              "bounds": "Additional-functions/Mechanisms.m case 'Case2': nvars = 6, r1..r4 in [0, 50], rcx, rcy in "
                        "[-50, 50]; Objf2.m adds no rotation or translation (θ0 = x0 = y0 = 0)",
              "best_error": "the issue's best known (7.4158e-7); this benchmark reaches it (see README)"},
    note=("Six variables r1..r4, rcx, rcy; the ground link along +x from the origin. The repository's Cons2.m "
          "adds order conditions between the links that this benchmark does not impose; explorer needs a crank "
          "that turns a full cycle instead."),
    published="1.924e-6 in 1 of 50 runs (5,000 evaluations), Nguyen-Van et al. 2022",
)

VERTICAL_LINE = SynthesisProblem(
    name=VERTICAL_LINE.name, source=VERTICAL_LINE.source + "; " + _NGUYEN_VAN + ", Case1 (Objf1.m, Mechanisms.m)",
    points=VERTICAL_LINE.points, angles=None,
    bounds={"r1": (0.0, 60.0), "r2": (0.0, 60.0), "r3": (0.0, 60.0), "r4": (0.0, 60.0),
            "rcx": (-60.0, 60.0), "rcy": (-60.0, 60.0), "theta0": (0.0, 2.0 * math.pi),
            "x0": (-60.0, 60.0), "y0": (-60.0, 60.0)},
    budget="100,000 evaluations (the issue's table)", evaluations=100_000, best_error=0.0,
    verified={**VERTICAL_LINE.verified,
              "points": "Case1/Objf1.m: Cdx=[20 20 20 20 20 20]; Cdy=[20 25 30 35 40 45] (and IMECE2019-10262)",
              "bounds": "Additional-functions/Mechanisms.m case 'Case1': nvars = 15; r1..r4 in [0, 60]; rcx, rcy, "
                        "x0, y0 in [-60, 60]; θ0 and the six θ2_i in [0, 2π] (Objf1.m: x = [r1 r2 r3 r4 rcx rcy "
                        "x0 y0 θ0 θ2_1 … θ2_6])"},
    note=VERTICAL_LINE.note + (" Cons1.m requires a Grashof linkage whose crank is the shortest link and the "
                               "θ2_i in increasing order (sequence.m); the order is reported, not imposed."),
    published="8.84e-29 in 2 of 50 runs (100,000 evaluations), Nguyen-Van et al. 2022",
)

CLOSED_TIMED = SynthesisProblem(
    name="closed-timed",
    source=_NGUYEN_VAN + ", Case3 (Objf3.m, Cons3.m, Mechanisms.m)",
    points=CLOSED_POINTS,
    angles=tuple(i * math.pi / 9 for i in range(18)),
    bounds=_CLOSED_BOUNDS,
    budget="5,000 evaluations (the issue's table)",
    evaluations=5000,
    best_error=9.029e-3,
    verified={"points": "Case3/Objf3.m (CLOSED_POINTS)",
              "angles": "Case3/Objf3.m: teta2 = x(10) + (i-1)*(pi/9): 20° steps from a free start angle",
              "bounds": "Mechanisms.m case 'Case3': nvars = 10; r1..r4 in [0, 50]; rcx, rcy, x0, y0 in [-50, 50]; "
                        "θ0 and the start angle in [0, 2π]",
              "best_error": "the issue's best known (9.029e-3): a compact Grashof crank-rocker (r1 1.054, r2 0.424, "
                            "r3 0.914, r4 0.599, rcx 0.371, rcy 0.399, x0 0.268, y0 0.155, θ0 0.285, φ 0.892 reach "
                            "9.0289e-3 here by least squares from random starts; it turns a full cycle)"},
    note=("Ten variables: the nine and the start angle φ (timed angles θ2_i = φ + 20°·i). Cons3.m asks for a "
          "Grashof linkage only (the crank-is-shortest test is commented out); explorer turns the crank a full "
          "cycle, so its designs are crank-rockers or double cranks."),
    phase=True,
    published="1.608e-2, on its box bound (5,000 evaluations), Nguyen-Van et al. 2022",
)

CLOSED_UNTIMED = SynthesisProblem(
    name="closed-untimed",
    source=("Bulatović, R.R., et al., Mechanism and Machine Theory 95 (2016) (the published mechanism, 4.96e-3); "
            "the points of " + _NGUYEN_VAN + ", Case3"),
    points=CLOSED_POINTS,
    angles=None,
    bounds=_CLOSED_BOUNDS,
    budget=None,
    evaluations=None,
    best_error=3.14e-3,
    verified={"points": "Case3/Objf3.m of the Nguyen-Van repository (the same 18 points)",
              "bounds": "those of Case3 (Mechanisms.m) for the nine; the 18 θ2_i in [0, 2π]; Bulatović's own "
                        "bounds NOT verified",
              "budget": False,
              "best_error": "the issue's best known (3.14e-3)"},
    note=("27 variables: the nine and one crank angle per point. The literature requires the points in order "
          "along the path; explorer's free angles do not impose it, the benchmark reports whether it holds."),
    published="4.96e-3 (the published mechanism of Bulatović et al., MMT 95, 2016)",
)

#: The ten points of Nguyen-Van et al.'s fifth case, as written in Case5/Objf5.m of their repository ("C1=[20;10];
#: C2=[17.66;15.142]; C3=[11.736;17.878]; C4=[5;16.928]; C5=[0.60307;12.736]; C6=[0.60307;7.2638]; C7=[5;3.0718];
#: C8=[11.736;2.1215]; C9=[17.66;4.8577]; C10=[20;10];"): the ellipse of semi-axes 10 (x) and 8 (y) about (10, 10)
#: at 40° steps of its parameter, to 3-5 digits, the first point repeated last.
ELLIPSE_POINTS = ((20.0, 10.0), (17.66, 15.142), (11.736, 17.878), (5.0, 16.928), (0.60307, 12.736), (0.60307, 7.2638),
                  (5.0, 3.0718), (11.736, 2.1215), (17.66, 4.8577), (20.0, 10.0))

ELLIPSE_TEN = SynthesisProblem(
    name="ellipse-ten",
    source=_NGUYEN_VAN + ", Case5 (Objf5.m, Cons5.m, Mechanisms.m)",
    points=ELLIPSE_POINTS,
    angles=None,
    bounds={"r1": (0.0, 80.0), "r2": (0.0, 80.0), "r3": (0.0, 80.0), "r4": (0.0, 80.0),
            "rcx": (-80.0, 80.0), "rcy": (-80.0, 80.0), "theta0": (0.0, 2.0 * math.pi),
            "x0": (-80.0, 80.0), "y0": (-80.0, 80.0)},
    budget="100,000 evaluations (Records_DE_Case5.txt: 1e5 per run)",
    evaluations=100_000,
    best_error=4.0199e-4,
    verified={"points": "Case5/Objf5.m (ELLIPSE_POINTS)",
              "bounds": "Mechanisms.m case 'Case5': nvars = 19; r1..r4 in [0, 80]; rcx, rcy, x0, y0 in [-80, 80]; θ0 and "
                        "the ten θ2_i in [0, 2π] (Objf5.m: x = [r1 r2 r3 r4 rcx rcy x0 y0 θ0 θ2_1 … θ2_10])",
              "constraints": "Cons5.m: Grashof (the crank-is-shortest test commented out) and the θ2_i in cyclic "
                             "order from the smallest (INDEX.m, sequence.m)",
              "best_error": "the issue's best known (4.0199e-4, r1 on its bound 80); x_best_HCDJ_Case5.txt scores "
                            "4.2014e-4 by Objf5.m's closed form at its own angles (checked in tests/test_rounds.py)"},
    note=("19 variables: the nine and one crank angle per point; the first point twice (the path must pass it at "
          "two crank angles, which explorer's closest matching counts twice, as the source does)."),
    published="4.2014e-4 (x_best_HCDJ_Case5, Nguyen-Van et al. 2022)",
)

#: The problems, by name: the issue's four (vertical-line, timed-five, closed-timed, closed-untimed), the fifth case
#: (ellipse-ten) and the nine-variable timed five (``timed-five-free``: θ0, x0, y0 free) the pylinkage comparison
#: was built on. studies/literature/ holds the first five as study files.
TIMED_FIVE = SynthesisProblem(**{**TIMED_FIVE.__dict__, "name": "timed-five-free"})
PROBLEMS = {p.name: p for p in (VERTICAL_LINE, TIMED_FIVE_ORIGIN, CLOSED_TIMED, CLOSED_UNTIMED, TIMED_FIVE, ELLIPSE_TEN)}
#: The issue's four.
LITERATURE = ("vertical-line", "timed-five", "closed-timed", "closed-untimed")

#: A four-bar (the variables of :data:`VARIABLES`, and its branch) through TIMED_FIVE's points at their
#: crank angles, found for this file by least squares from random starts (scipy): sum of squared
#: distances 2.71e-7 (RMS 2.3e-4), the level of the data's 3-decimal rounding; three other, different
#: four-bars reach the same 2.71e-7. A Grashof crank-rocker (the crank, r2, is the shortest link), so it
#: turns a full cycle in explorer. It lies outside the bounds listed above (r3 > 5), which are not verified.
CONSISTENT_TIMED_FIVE = ({"r1": 5.180819, "r2": 1.994293, "r3": 5.315809, "r4": 2.317714, "rcx": 3.783727,
                          "rcy": 4.990404, "theta0": 0.000171, "x0": -2.120276, "y0": -3.26111}, +1)
CONSISTENT_TIMED_FIVE_SUMSQ = 2.71e-7


def fourbar_points(r1, r2, r3, r4, rcx, rcy, theta0, x0, y0, theta2, *, branch: int = 1):
    """Coupler point C (x, y) of the four-bar at crank angles θ2 (radians, from the ground link), in
    plain math (no numpy): a list of (x, y), None where the linkage cannot be assembled."""
    out = []
    o4x, o4y = x0 + r1 * math.cos(theta0), y0 + r1 * math.sin(theta0)
    for t2 in theta2:
        ax, ay = x0 + r2 * math.cos(theta0 + t2), y0 + r2 * math.sin(theta0 + t2)
        gx, gy = o4x - ax, o4y - ay
        d = math.hypot(gx, gy)
        if d == 0.0:
            out.append(None)
            continue
        a = (r3 * r3 - r4 * r4 + d * d) / (2.0 * d)
        h2 = r3 * r3 - a * a
        if h2 < 0.0:
            out.append(None)
            continue
        hh = math.sqrt(h2)
        ux, uy = gx / d, gy / d
        bx, by = ax + a * ux - branch * hh * uy, ay + a * uy + branch * hh * ux
        ex, ey = (bx - ax) / r3, (by - ay) / r3
        out.append((ax + rcx * ex - rcy * ey, ay + rcx * ey + rcy * ex))
    return out


def fourbar_mechanism_dict(r1, r2, r3, r4, rcx, rcy, theta0, x0, y0, *, branch: int = 1,
                           name: str = "fourbar-synthesis") -> dict:
    """An explorer mechanism table (the TOML shape; load it with
    ``explorer.mechanism.mechanism_from_dict(d, source)``) for the four-bar of the parametrisation in
    this module's docstring.

    Vertices: the crank pin ``A`` (the crank: centre (x0, y0), radius r2), the rocker pivot ``B0``
    (fixed, r1 from the crank centre at angle θ0), the rocker pin ``B`` (link ``rocker``, length r4) and
    the coupler point ``P``, the foot. The coupler is one rigid body ``coupler`` with joints A = (0, 0),
    B = (r3, 0), P = (rcx, rcy) in its own frame: exactly the source's coupler frame. The guess puts B
    on side ``branch`` of the line A → B0 at explorer's crank angle θ = 0 (θ2 = −θ0), so explorer
    follows that assembly; where the linkage cannot be assembled at θ = 0 the guess lies on the line
    A → B0 and the simulation reports the failure. explorer turns the crank a full cycle: a design
    whose crank cannot turn fully fails, even if it could reach a timed problem's angles.

    The design parameters of the mechanism (``Mechanism.parameters()``) are then: ``crank`` = r2,
    ``crank.x`` = x0, ``crank.y`` = y0, ``B0.x``, ``B0.y`` (= crank centre + r1·(cos θ0, sin θ0)),
    ``rocker`` = r4, ``coupler.B.x`` = r3, ``coupler.P.x`` = rcx, ``coupler.P.y`` = rcy (and
    ``coupler.A.x``, ``coupler.A.y``, ``coupler.B.y``, which must stay 0 for rcx, rcy to keep the source's
    meaning); see :func:`explorer_parameters`.
    """
    if branch not in (1, -1):
        raise ValueError(f"branch: expected +1 or -1, got {branch!r}")
    o4 = (x0 + r1 * math.cos(theta0), y0 + r1 * math.sin(theta0))
    ax, ay = x0 + r2, y0  # explorer's θ = 0
    p = fourbar_points(r1, r2, r3, r4, rcx, rcy, theta0, x0, y0, [-theta0], branch=branch)[0]
    gx, gy = o4[0] - ax, o4[1] - ay
    d = math.hypot(gx, gy) or 1.0
    ux, uy = gx / d, gy / d
    if p is not None:
        a = (r3 * r3 - r4 * r4 + d * d) / (2.0 * d)
        hh = math.sqrt(max(r3 * r3 - a * a, 0.0))
        b = (ax + a * ux - branch * hh * uy, ay + a * uy + branch * hh * ux)
    else:  # not assemblable at θ = 0: a guess on the line A → B0 (the solver reports the failure)
        b = (ax + r3 * ux, ay + r3 * uy)
        ex, ey = ux, uy
        p = (ax + rcx * ex - rcy * ey, ay + rcx * ey + rcy * ex)
    return {
        "name": name,
        "description": (f"Four-bar for path synthesis: r1={r1!r}, r2={r2!r}, r3={r3!r}, r4={r4!r}, rcx={rcx!r}, "
                        f"rcy={rcy!r}, theta0={theta0!r}, x0={x0!r}, y0={y0!r}, branch={branch:+d}"),
        "foot": "P",
        "crank": {"center": [float(x0), float(y0)], "radius": float(r2), "tip": "A"},
        "fixed": {"B0": [float(o4[0]), float(o4[1])]},
        "guess": {"B": [float(b[0]), float(b[1])], "P": [float(p[0]), float(p[1])]},
        "links": [{"name": "rocker", "a": "B0", "b": "B", "length": float(r4)}],
        "bodies": [{"name": "coupler", "joints": {"A": [0.0, 0.0], "B": [float(r3), 0.0],
                                                  "P": [float(rcx), float(rcy)]}}],
    }


def explorer_parameters(r1, r2, r3, r4, rcx, rcy, theta0, x0, y0) -> dict:
    """The explorer design parameters (names of ``Mechanism.parameters()``) of the mechanism
    :func:`fourbar_mechanism_dict` builds, from the source's variables."""
    return {"crank": r2, "crank.x": x0, "crank.y": y0, "B0.x": x0 + r1 * math.cos(theta0),
            "B0.y": y0 + r1 * math.sin(theta0), "rocker": r4, "coupler.B.x": r3, "coupler.P.x": rcx,
            "coupler.P.y": rcy}


def source_variables(params: dict) -> dict:
    """The inverse of :func:`explorer_parameters`: r1 … y0 (θ0 in [0, 2π)) from explorer parameters."""
    x0, y0 = params["crank.x"], params["crank.y"]
    gx, gy = params["B0.x"] - x0, params["B0.y"] - y0
    return {"r1": math.hypot(gx, gy), "r2": params["crank"], "r3": params["coupler.B.x"], "r4": params["rocker"],
            "rcx": params["coupler.P.x"], "rcy": params["coupler.P.y"],
            "theta0": math.atan2(gy, gx) % (2.0 * math.pi), "x0": x0, "y0": y0}
