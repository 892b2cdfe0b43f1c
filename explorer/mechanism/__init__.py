"""Mechanisms as data: the linkage graph, its TOML files, and the built-ins."""

from ._load import builtin_mechanisms, load_mechanism, mechanism_from_dict
from ._model import Crank, Link, Mechanism, PathDriver

__all__ = ["Crank", "Link", "Mechanism", "PathDriver", "builtin_mechanisms", "load_mechanism", "mechanism_from_dict"]
