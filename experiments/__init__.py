"""Studies: Hydra configurations, the ``metaknot run`` app and the Parquet results store
(installed as ``metaknot.experiments``).

``load_study(path)`` reads a study directory back as pandas tables; see
:mod:`metaknot.experiments.store`. The Hydra pieces load only when a run or sweep starts.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .store import Store, StoreError, Study, load_study

__all__ = ["Store", "StoreError", "Study", "load_study"]


def __getattr__(name: str) -> Any:
    if name in __all__:
        from . import store

        return getattr(store, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
