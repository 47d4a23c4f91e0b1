"""Registries an extension adds to: named entries that hold behaviour, read in order.

A registry maps a name to the entry that does the work (as rosbags' ``Typestore`` maps a
message name to its type, and ``Typestore.register`` adds one at run time): the method's
:class:`~twopose.methods.specs.MethodSpec`, the target's
:class:`~twopose.values.choices.TargetSpec`,
a frame source's kind (``recorder.sources.registry``), a constraint plane
(:class:`~twopose.methods.planes.ConstraintPlane`). twopose's own entries are registered on
import; an extension calls the registry's ``register_*`` function (for example
:func:`twopose.methods.specs.register_method`) before it uses the entry, and every stage reads
the entry from the registry, in the process that registered it.

- :class:`Registry`: the mapping itself, keyed by name, in registration order; what is
  registered is checked once, when it is registered (a name taken twice is refused).
- :class:`Name`: a registered entry's name as a type (``str`` underneath, so files,
  tables and JSON carry it as it is); ``Method("wall")`` is the registered method of that
  name, or a :class:`ValueError` naming the registered ones.
- :class:`Listing`: a read-only sequence derived from a registry (the methods' names, the
  planes), always as the registry is now.
- :func:`load_extensions`: the modules installed packages name under the entry-point
  group ``twopose.extensions`` (:data:`ENTRY_POINT_GROUP`), imported once, so that their
  ``register_*`` calls run: the command lines load them before reading their choices, and
  a registry loads them when asked for a name it does not hold (a spawned worker
  unpickling an extension's method).

This module imports nothing heavy: the command lines read the registries at start-up.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping, Sequence
from typing import Any, ClassVar, Self, TypeVar, overload

__all__ = ["ENTRY_POINT_GROUP", "Listing", "Name", "Registry", "load_extensions"]

#: The entry-point group an extension's package names its module under (``[project.
#: entry-points."twopose.extensions"]`` in its ``pyproject.toml``: ``wall = "wall_ext"``).
ENTRY_POINT_GROUP = "twopose.extensions"
_loaded: list[str] = []  # the extensions' modules imported, once each (empty: not yet)
_loading = [False]


def load_extensions() -> tuple[str, ...]:
    """Import every module named under :data:`ENTRY_POINT_GROUP`, once; their names.

    An extension that fails to import is said in a warning naming it and the error, and
    left out: the registries stay as they were.
    """
    if _loaded or _loading[0]:
        return tuple(_loaded[1:])
    _loading[0] = True
    try:
        import warnings
        from importlib import import_module
        from importlib.metadata import entry_points

        _loaded.append("")  # loaded (the marker), whatever follows
        for point in entry_points(group=ENTRY_POINT_GROUP):
            try:
                import_module(point.value.split(":")[0])
            except Exception as err:  # any failure of another's code is said, not raised
                warnings.warn(
                    f"twopose extension {point.name!r} ({point.value}) failed to load and "
                    f"is left out: {type(err).__name__}: {err}",
                    stacklevel=2,
                )
            else:
                _loaded.append(point.value)
    finally:
        _loading[0] = False
    return tuple(_loaded[1:])


K = TypeVar("K", bound=str)
V = TypeVar("V")
T = TypeVar("T")


class Registry(Mapping[K, V]):
    """Entries by name, in the order they were registered; an extension adds its own.

    ``what`` names an entry in messages ("method"); ``key`` gives an entry's name.
    """

    def __init__(self, what: str, key: Callable[[V], K], entries: Sequence[V] = ()) -> None:
        self.what = what
        self._key = key
        self._entries: dict[K, V] = {}
        self._keys: dict[str, K] = {}  # each name by its text: the registered key itself
        #: The names, in order, as one list kept current (a JSON Schema's ``enum`` holds
        #: it, so that a file written after a registration may name the new entry).
        self.names: list[str] = []
        #: How many times the registry changed: what a :class:`Listing` caches by.
        self.generation = 0
        for one in entries:
            self.register(one)

    def register(self, entry: V) -> V:
        """Add ``entry`` under its name (:class:`ValueError` if the name is taken)."""
        name = self._key(entry)
        if name in self._entries:
            raise ValueError(f"a {self.what} named {str(name)!r} is already registered")
        self._entries[name] = entry
        self._keys[str(name)] = name
        self.names.append(str(name))
        self.generation += 1
        return entry

    def unregister(self, name: str) -> V:
        """Remove the entry ``name`` (an extension's, e.g. when a test ends) and return it."""
        key = self.key_of(name)
        entry = self._entries.pop(key)
        del self._keys[str(key)]
        self.names.remove(str(key))
        self.generation += 1
        return entry

    def key_of(self, name: object) -> K:
        """The registered name equal to ``name`` (:class:`ValueError` listing them if none)."""
        if isinstance(name, str) and str(name) in self._keys:
            return self._keys[str(name)]
        if isinstance(name, str) and not _loaded:  # an installed extension's, perhaps
            load_extensions()
            if str(name) in self._keys:
                return self._keys[str(name)]
        known = ", ".join(self.names)
        raise ValueError(f"{self.what} must be one of {known}, got {name!r}")

    def __getitem__(self, name: K) -> V:
        """The entry or item at ``name`` / ``index``."""
        return self._entries[name]

    def __iter__(self) -> Iterator[K]:
        """In order, as it is now."""
        return iter(tuple(self._entries))

    def __len__(self) -> int:
        """How many."""
        return len(self._entries)

    def __repr__(self) -> str:
        """What it is, as Python would write it."""
        return f"Registry({self.what}: {', '.join(self.names)})"


class Listing(Sequence[T]):
    """A read-only sequence derived from registries by ``derive``, as they are now.

    Recomputed when one of ``registries`` has changed since it was last read; it compares
    equal to a sequence of the same items (``METHODS == ("point", "line", ...)``).
    """

    def __init__(self, derive: Callable[[], Sequence[T]], *registries: Registry[Any, Any]) -> None:
        self._derive = derive
        self._registries = registries
        self._seen: tuple[int, ...] = ()
        self._items: tuple[T, ...] = ()

    def _now(self) -> tuple[T, ...]:
        seen = tuple(r.generation for r in self._registries)
        if seen != self._seen or not self._registries:
            self._items, self._seen = tuple(self._derive()), seen
        return self._items

    @overload
    def __getitem__(self, index: int) -> T: ...
    @overload
    def __getitem__(self, index: slice) -> tuple[T, ...]: ...
    def __getitem__(self, index: int | slice) -> T | tuple[T, ...]:
        """The entry or item at ``name`` / ``index``."""
        return self._now()[index]

    def __len__(self) -> int:
        """How many."""
        return len(self._now())

    def __iter__(self) -> Iterator[T]:
        """In order, as it is now."""
        return iter(self._now())

    def __contains__(self, item: object) -> bool:
        """Whether ``item`` is one of them."""
        return item in self._now()

    def __eq__(self, other: object) -> bool:
        """Whether ``other`` is a sequence of the same items."""
        if isinstance(other, Sequence) and not isinstance(other, str):
            return self._now() == tuple(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]  # it changes with the registry

    def __add__(self, other: Sequence[T]) -> tuple[T, ...]:
        """The items, then ``other``'s, as a tuple."""
        return self._now() + tuple(other)

    def __repr__(self) -> str:
        """What it is, as Python would write it."""
        return repr(self._now())


class Name(str):
    """A registered entry's name, as a type: a ``str`` its registry holds.

    ``str`` underneath, so files, tables and JSON carry it as it is.

    ``Kind("x")`` is the registered name equal to ``"x"`` (:class:`ValueError` naming the
    registered ones otherwise, as an :class:`~enum.Enum` does); :meth:`declare` makes a new
    one for an entry about to be registered. A subclass sets :attr:`registry`.
    """

    __slots__ = ()
    #: The registry whose names this type holds (set by the subclass' module).
    registry: ClassVar[Registry[Any, Any]]

    def __new__(cls, name: object) -> Self:
        """The registered name equal to ``name`` (a :class:`ValueError` otherwise)."""
        found = cls.registry.key_of(name)
        if not isinstance(found, cls):  # pragma: no cover - a registry of another type
            raise TypeError(f"{cls.__name__}'s registry holds {type(found).__name__}")
        return found

    @classmethod
    def declare(cls, name: str) -> Self:
        """A new name, for an entry to register (its registry's ``register_*`` function)."""
        if not isinstance(name, str) or not name or name != name.strip():
            raise ValueError(f"a {cls.__name__} name must be a word, got {name!r}")
        return str.__new__(cls, name)

    @property
    def value(self) -> str:
        """The name as a plain string (as an enum member's ``value``)."""
        return str(self)

    def __repr__(self) -> str:
        """What it is, as Python would write it."""
        return f"{type(self).__name__}({str(self)!r})"

    def __reduce__(self) -> tuple[Any, ...]:
        """Unpickled as the registered name (a pickled table in another process)."""
        return (type(self), (str(self),))
