"""Progress bars on stderr, and the one shape every stage takes them in."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator
from typing import TypeVar

T = TypeVar("T")

#: How a stage shows progress: ``(items, description, total) -> items`` (an iterator over the same items).
Progress = Callable[[Iterable, str, "int | None"], Iterable]


def progress_bar(items: Iterable[T], desc: str, enabled: bool, total: int | None = None,
                 position: int | None = None) -> Iterator[T]:
    """Wrap ``items`` in a tqdm progress bar on stderr when ``enabled`` (on terminal line ``position``)."""
    if not enabled:
        yield from items
        return
    from tqdm import tqdm

    yield from tqdm(items, desc=desc, total=total, leave=False, dynamic_ncols=True, unit="frame", position=position)


def bars(position: int | None = None) -> Progress:
    """A :data:`Progress` that draws tqdm bars (on terminal line ``position``: ``track --workers`` gives
    each worker its own line under the overall bar)."""
    return lambda items, desc, total=None: progress_bar(items, desc, True, total, position)


def as_progress(progress: "bool | Progress") -> Progress:
    """``progress`` as the stages use it: a :data:`Progress`; True draws bars, False shows nothing."""
    if callable(progress):
        return progress
    return bars() if progress else (lambda items, desc, total=None: items)
