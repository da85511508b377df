"""YAML files people write (building.yaml, map_server map files): ``yaml.safe_load`` that refuses a key given
twice in one mapping. Plain YAML keeps the last value and drops the first without a word: a location with two
``pose:`` lines would silently use the second."""

from __future__ import annotations

import yaml
from yaml.nodes import MappingNode


class DuplicateKeyError(yaml.YAMLError):
    """A key given twice in one mapping; ``line`` and ``first_line`` are 1-based, the values as written."""

    def __init__(self, key: object, line: int, value: object, first_line: int, first_value: object) -> None:
        self.key, self.line, self.value, self.first_line, self.first_value = key, line, value, first_line, first_value
        super().__init__(f"line {line}: {self.problem}")

    @property
    def problem(self) -> str:
        return (f"key {self.key!r} is given twice in one mapping: {_short(self.first_value)} on line "
                f"{self.first_line}, {_short(self.value)} on line {self.line} (YAML would silently keep the last)")


def _short(value: object) -> str:
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


class _UniqueKeyLoader(yaml.SafeLoader):
    def construct_mapping(self, node: MappingNode, deep: bool = False) -> dict:
        if isinstance(node, MappingNode):
            seen: dict[object, tuple[int, object]] = {}
            for key_node, value_node in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue                    # '<<': merged keys may be overridden, that is what it is for
                key = self.construct_object(key_node, deep=True)
                try:
                    first = seen.get(key)
                except TypeError:
                    continue                    # an unhashable key: SafeLoader reports it
                value = self.construct_object(value_node, deep=True)
                if first is not None:
                    raise DuplicateKeyError(key, key_node.start_mark.line + 1, value, first[0] + 1, first[1])
                seen[key] = (key_node.start_mark.line, value)
        return super().construct_mapping(node, deep=deep)


def load_yaml(text: str) -> object:
    """``yaml.safe_load`` of ``text``, raising :class:`DuplicateKeyError` (a ``yaml.YAMLError``) for a key given
    twice in one mapping."""
    return yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 - a SafeLoader subclass
