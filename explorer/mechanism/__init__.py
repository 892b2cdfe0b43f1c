"""Mechanisms as data: the linkage graph, its TOML files, and the built-ins."""

from ._load import MECHANISM_KEYS, OPERATING_KEYS, WALKER_KEYS, builtin_mechanisms, load_mechanism, mechanism_from_dict, operating_from_dict, parse_toml, walker_body, walker_from_dict
from ._toml import dumps_toml, mechanism_toml
from ._mass import crank_masses, effective_mass, link_masses
from ._model import BODY_MODELS, LENGTH_RANGE, Body, Crank, Gear, Link, Mechanism, Operating, PathDriver, Slider, Walker

__all__ = ["crank_masses", "effective_mass", "link_masses", "dumps_toml", "mechanism_toml", "BODY_MODELS", "LENGTH_RANGE", "MECHANISM_KEYS", "OPERATING_KEYS", "WALKER_KEYS", "Body", "Crank", "Gear", "Link", "Mechanism", "Operating", "PathDriver", "Slider", "Walker", "builtin_mechanisms", "load_mechanism",
           "mechanism_from_dict", "operating_from_dict", "parse_toml", "walker_body", "walker_from_dict"]

from ._model import EULER_SEQUENCES, INTERPOLATIONS, Orientation, valid_sequence  # noqa: E402

__all__ += ["EULER_SEQUENCES", "INTERPOLATIONS", "Orientation", "valid_sequence"]

from ._build import BUILD_KEYS, PIN_MATERIALS, SHEET_MATERIALS, Build, build_from_dict  # noqa: E402

__all__ += ["BUILD_KEYS", "PIN_MATERIALS", "SHEET_MATERIALS", "Build", "build_from_dict"]
