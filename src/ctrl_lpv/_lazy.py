"""Lazy public names of a package (PEP 562).

A package lists its public names in one table, name -> submodule, and calls
`install`; a name's submodule is imported the first time the name is read
(``import ctrl_lpv`` then costs no python-control, cvxpy or matplotlib
import). ``from package import *``, `dir` and Sphinx autodoc see every name.
"""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Mapping

__all__ = ["install"]


class _LazyPackage(types.ModuleType):
    """A package whose public functions keep their name over a submodule's.

    After importing a submodule the import system binds it on its package
    (``setattr(package, "reproduce", <module>)``). Where a public name is
    also a submodule name (``twomass.reproduce``, ``twomass.plant``) the
    public object, not the module, keeps the name, as with eager imports.
    """

    def __setattr__(self, name: str, value) -> None:
        exports = self.__dict__.get("_EXPORTS", {})
        if (
            isinstance(value, types.ModuleType)
            and value.__name__ == f"{self.__name__}.{name}"
            and name in exports
            and exports[name] == name
            and hasattr(value, name)
        ):
            value = getattr(value, name)
        super().__setattr__(name, value)


def install(package: str, exports: Mapping[str, str]):
    """Make the names of `exports` lazy attributes of `package`.

    Parameters
    ----------
    package : str
        ``__name__`` of the package (its ``__init__`` calls this).
    exports : mapping of str to str
        Public name -> submodule (relative to `package`) that defines it.

    Returns
    -------
    getattr, dir : callable
        The package's module-level ``__getattr__`` and ``__dir__``.
    """
    module = sys.modules[package]
    module.__dict__["_EXPORTS"] = dict(exports)
    module.__class__ = _LazyPackage

    def __getattr__(name: str):
        if name in exports:
            source = importlib.import_module(f"{package}.{exports[name]}")
            value = getattr(source, name)
            module.__dict__[name] = value
            return value
        if not name.startswith("__"):
            # Submodules (``ctrl_lpv.lmi``) as after an eager import.
            try:
                return importlib.import_module(f"{package}.{name}")
            except ModuleNotFoundError as exc:
                if exc.name != f"{package}.{name}":
                    raise
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(module.__dict__) | set(exports))

    return __getattr__, __dir__
