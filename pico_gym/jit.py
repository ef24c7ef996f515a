"""numba's `njit` with its on-disk cache in the user's cache directory, never in the package.

`numba.njit(cache=True)` writes its cache files into a `__pycache__` folder next to the source,
that is, inside the installed package. `pip uninstall` does not know those files and leaves the
folders behind, and Python then takes the leftover `pico_gym/...` folders for namespace packages
that hide a later (e.g. editable) install. `njit` here caches the same kernels in numba's
user-wide cache directory instead (`NUMBA_CACHE_DIR` if the user set one, else the platform's
user cache, e.g. ~/.cache/numba), keyed by the source file's path and contents as numba's own
cache is, and by the contents of every module of the package: numba's own key holds only the
function's bytecode, so a kernel that calls another module's kernel (the vector batch calls the
env's `_drive`) would otherwise run its stale machine code after that module changed. Where that
cannot be set up, the kernels compile in memory only.
"""

from __future__ import annotations

import functools
import hashlib
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numba

F = TypeVar("F", bound=Callable[..., Any])

try:  # numba's cache classes are internal; without them the kernels compile in memory only.
    from numba.core.caching import (
        CompileResultCacheImpl,
        FunctionCache,
        UserProvidedCacheLocator,
        UserWideCacheLocator,
    )

    class _UserCacheImpl(CompileResultCacheImpl):
        _locator_classes = [UserProvidedCacheLocator, UserWideCacheLocator]

    class _UserCache(FunctionCache):
        """numba's function cache, located outside the source tree, keyed by the package too."""

        _impl_class = _UserCacheImpl

        def _index_key(self, sig: Any, codegen: Any) -> Any:
            return (*super()._index_key(sig, codegen), package_digest())

except ImportError:  # pragma: no cover - depends on the numba version
    _UserCache = None  # type: ignore[assignment,misc]


@functools.cache
def package_digest() -> str:
    """A digest of every module of the package (its path and contents), read once a process."""
    root = Path(__file__).resolve().parent
    # Installed, pico_gym.agents and pico_gym.train lie inside the package; in a source checkout
    # (an editable install) they are its siblings agents/ and train/.
    checkout = (root.parent / "pyproject.toml").is_file()
    trees = [root] + ([root.parent / "agents", root.parent / "train"] if checkout else [])
    digest = hashlib.sha256()
    for tree in trees:
        for path in sorted(tree.rglob("*.py")):
            digest.update(str(path.relative_to(root.parent)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def njit(function: F | None = None, **options: Any) -> Any:
    """Compile `function` with `numba.njit`, caching the machine code in the user cache directory.

    Used bare (`@njit`) or with numba's options (`@njit(fastmath={"contract"})`)."""
    if function is None:
        return lambda f: njit(f, **options)
    dispatcher = numba.njit(cache=False, **options)(function)
    if _UserCache is not None:
        try:
            dispatcher._cache = _UserCache(function)
        except RuntimeError:  # no writable user cache directory: compile in memory only
            pass
    return dispatcher
