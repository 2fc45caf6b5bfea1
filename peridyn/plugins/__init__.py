"""Plugin machinery: the hook specifications, the registry, the built-ins and the scaffold.

Third-party plugins mark their hook functions with :data:`hookimpl`.
"""
from .hookspecs import hookimpl

__all__ = ["hookimpl"]
