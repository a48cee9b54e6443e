"""JSON Schemas of the ``/info`` type descriptions: what a port's or a service's JSON data looks like.

One converter serves every place that describes genom3 JSON to other tools: the
gateway's OpenAPI document (named models under ``#/components/schemas/``), a
recording's JSON channels (a self-contained schema per channel, its structs under
``$defs``), a live view's channels.  It reads the ``/info`` descriptions
(:meth:`IdlType.describe`), so a component host, a recorder on another machine or a
client holding only ``/info`` makes the same schemas.

A number's unit, where its component declares one, is the schema's ``x-unit`` (``"deg"``), and what
a struct's data is, where its type declares a port kind, the struct schema's ``x-carries`` (the
``carries`` object of ``/info``): JSON Schema keeps keywords it does not know as annotations, and
OpenAPI takes ``x-`` extensions anywhere.

Data comes in two directions that genom3 writes differently:

* **input** (what a service accepts): enums by full or short name, booleans, members optional,
  no member beyond those declared;
* **output** (what a component writes: port data, outputs): enums by full name, booleans
  as 0 or 1, NaN as ``null``, every member present.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

__all__ = ["JsonSchemas", "json_schema", "schema_name", "INTEGER_RANGES"]

Json = dict[str, Any]

#: The range of each IDL integer kind (genom3 refuses values outside it).
INTEGER_RANGES = {
    "octet": (0, 2**8 - 1), "short": (-(2**15), 2**15 - 1), "unsigned short": (0, 2**16 - 1),
    "long": (-(2**31), 2**31 - 1), "unsigned long": (0, 2**32 - 1),
    "long long": (-(2**63), 2**63 - 1), "unsigned long long": (0, 2**64 - 1),
}

#: The JSON Schema dialect of :func:`json_schema` (the one OpenAPI 3.1 uses too).
DIALECT = "https://json-schema.org/draft/2020-12/schema"


def schema_name(*parts: str) -> str:
    """An identifier made of *parts*, fit for generated code (``::demo::state`` → ``demo_state``).

    >>> schema_name("::demo::state", "Input")
    'demo_state_Input'
    """
    return "_".join(p for p in (re.sub(r"\W+", "_", part).strip("_") for part in parts) if p)


class JsonSchemas:
    """Schemas of ``/info`` types, each struct named once per direction and referred to by ``$ref``.

    Args:
        ref_prefix: Where the named schemas live in the document that holds them
            (``#/$defs/`` for a schema of its own, ``#/components/schemas/`` in OpenAPI); None writes
            every struct in place.

    Attributes:
        named: The named schemas met so far, by name (put them where *ref_prefix* says).
    """

    def __init__(self, ref_prefix: str | None = "#/$defs/") -> None:
        self.ref_prefix = ref_prefix
        self.named: dict[str, Json] = {}

    def ref(self, name: str, schema: Json) -> Json:
        """Keep *schema* under *name* (the first one given wins) and return a reference to it.

        Without a *ref_prefix*, the schema itself is returned (written in place: IDL structs never
        contain themselves, so inlining ends), for readers that do not follow ``$ref``.
        """
        if self.ref_prefix is None:
            return schema
        self.named.setdefault(name, schema)
        return {"$ref": self.ref_prefix + name}

    def input(self, t: Mapping[str, Any]) -> Json:
        """The schema of data of type *t* as a service accepts it (short enum names, members optional)."""
        kind = t["kind"]
        if kind in INTEGER_RANGES:
            low, high = INTEGER_RANGES[kind]
            return {"type": "integer", "minimum": low, "maximum": high}
        if kind in ("float", "double"):
            # null is NaN, as genom3 writes it: taken, and refused by the components that check their
            # numbers (their request ends in error).
            return {"type": ["number", "null"]}
        if kind == "boolean":
            return {"type": "boolean"}  # genom3 reads 0 and 1 too
        if kind == "char":
            return {"type": "string", "minLength": 1, "maxLength": 1}
        if kind == "string":
            return {"type": "string", **({"maxLength": t["bound"]} if t.get("bound") else {})}
        if kind == "enum":
            # Full names come out; short names are accepted on input too.
            return {"type": "string", "enum": [*t["values"], *(v.rsplit("::", 1)[-1] for v in t["values"])]}
        if kind == "struct":
            return self.ref(schema_name(t["name"], "Input"), {
                "type": "object", "title": schema_name(t["name"], "Input"), "description": f"A {t['name']} as input",
                "additionalProperties": False,
                "properties": {m["name"]: self._member(m, self.input) for m in t["members"]}})
        if kind == "sequence":
            return {"type": "array", "items": self.input(t["element"]),
                    **({"maxItems": t["bound"]} if t.get("bound") else {})}
        if kind == "array":
            return {"type": "array", "items": self.input(t["element"]), "maxItems": t["length"]}
        if kind == "optional":
            return {"anyOf": [{"type": "null"}, self.input(t["element"])]}
        return {}

    def output(self, t: Mapping[str, Any]) -> Json:
        """The schema of data of type *t* as a component writes it (full enum names, NaN as null, every member)."""
        kind = t["kind"]
        if kind in ("float", "double"):
            return {"type": ["number", "null"]}
        if kind == "boolean":
            return {"type": "integer", "enum": [0, 1]}
        if kind == "enum":
            return {"type": "string", "enum": list(t["values"])}
        if kind == "struct":
            # Titled with the schema's own name: generators name their classes after it.
            return self.ref(schema_name(t["name"]), {
                "type": "object", "title": schema_name(t["name"]), "description": t["name"],
                "required": [m["name"] for m in t["members"]],
                "properties": {m["name"]: self._member(m, self.output) for m in t["members"]},
                **({"x-carries": t["carries"]} if isinstance(t.get("carries"), Mapping) else {})})
        if kind in ("sequence", "array"):
            return {"type": "array", "items": self.output(t["element"])}
        if kind == "optional":
            return {"anyOf": [{"type": "null"}, self.output(t["element"])]}
        return self.input(t)

    @staticmethod
    def described(schema: Json, member: Mapping[str, Any]) -> Json:
        """*schema* with what the ``/info`` *member* (or parameter) says of it: its doc, its unit (``x-unit``).

        A reference is left as it is (a struct member has no unit; its doc would hide the struct's).
        """
        if "$ref" in schema:
            return schema
        if member.get("doc"):
            schema = {**schema, "description": member["doc"]}
        if member.get("unit"):
            schema = {**schema, "x-unit": member["unit"]}
        return schema

    def _member(self, member: Mapping[str, Any], schema_of: Any) -> Json:
        return self.described(schema_of(member["type"]), member)


def json_schema(description: Mapping[str, Any], *, direction: str = "output", title: str | None = None,
                doc: str = "") -> Json:
    """A self-contained JSON Schema (draft 2020-12) of data of the ``/info`` type *description*.

    Every struct is written in place (no ``$ref``): the viewers of the robotics toolbox
    (Foxglove's JSON channels) want the root's ``type: object`` and its properties right there.

    Args:
        description: An ``/info`` type description (``port["type"]``, ``parameter["type"]``).
        direction: ``output`` for data a component writes (port data), ``input`` for what a service takes.
        title: The schema's title (default: the type's name).
        doc: Its description (what the data is, such as the port's documentation).

    Raises:
        ValueError: for a direction other than ``input`` or ``output``.
    """
    if direction not in ("input", "output"):
        raise ValueError(f"direction is input or output, not {direction!r}")
    schemas = JsonSchemas(None)
    root = schemas.output(description) if direction == "output" else schemas.input(description)
    document: Json = {"$schema": DIALECT, **root, "title": title or str(description.get("name", ""))}
    if doc:
        document["description"] = doc
    return document
