"""The OpenAPI 3.1 description of the gateway: its endpoints, and one path per service of every loaded module.

Built from the same ``/info`` descriptions the clients read, so that users of
any language can generate a client or browse the gateway in their usual tools.
A service's input travels as JSON in the ``input`` query parameter: OpenAPI
says so with a parameter whose ``content`` is ``application/json`` and whose
schema is derived from the service's ``in`` and ``inout`` parameters.
"""

from __future__ import annotations

from typing import Any

__all__ = ["openapi_document", "type_schema"]

Json = dict[str, Any]

#: The range of each IDL integer kind (genom3 refuses values outside it).
_INTEGER_RANGES = {
    "octet": (0, 2**8 - 1), "short": (-(2**15), 2**15 - 1), "unsigned short": (0, 2**16 - 1),
    "long": (-(2**31), 2**31 - 1), "unsigned long": (0, 2**32 - 1),
    "long long": (-(2**63), 2**63 - 1), "unsigned long long": (0, 2**64 - 1),
}

_ERROR = {"$ref": "#/components/schemas/Error"}
_TEXT = {"text/plain": {"schema": {"type": "string"}}}


def type_schema(t: Json) -> Json:
    """The JSON Schema of the data of IDL type *t* (a type description of ``/info``), as a service accepts it."""
    kind = t["kind"]
    if kind in _INTEGER_RANGES:
        low, high = _INTEGER_RANGES[kind]
        return {"type": "integer", "minimum": low, "maximum": high}
    if kind in ("float", "double"):
        return {"type": "number"}
    if kind == "boolean":
        # genom3 reads 0 and 1 as well as true and false.
        return {"anyOf": [{"type": "boolean"}, {"enum": [0, 1]}]}
    if kind == "char":
        return {"type": "string", "minLength": 1, "maxLength": 1}
    if kind == "string":
        schema: Json = {"type": "string"}
        if t.get("bound"):
            schema["maxLength"] = t["bound"]
        return schema
    if kind == "enum":
        # Full names come out; short names are accepted on input too.
        return {"type": "string", "enum": [*t["values"], *(v.rsplit("::", 1)[-1] for v in t["values"])]}
    if kind == "struct":
        return {"type": "object", "title": t["name"], "additionalProperties": False,
                "properties": {m["name"]: type_schema(m["type"]) for m in t["members"]}}
    if kind == "sequence":
        schema = {"type": "array", "items": type_schema(t["element"])}
        if t.get("bound"):
            schema["maxItems"] = t["bound"]
        return schema
    if kind == "array":
        return {"type": "array", "items": type_schema(t["element"]), "maxItems": t["length"]}
    if kind == "optional":
        return {"anyOf": [{"type": "null"}, type_schema(t["element"])]}
    return {}


def _output_schema(t: Json) -> Json:
    """The schema of data of type *t* as the gateway writes it (NaN as null, booleans as 0/1)."""
    kind = t["kind"]
    if kind in ("float", "double"):
        return {"type": ["number", "null"]}
    if kind == "boolean":
        return {"enum": [0, 1]}
    if kind == "enum":
        return {"type": "string", "enum": list(t["values"])}
    if kind == "struct":
        return {"type": "object", "properties": {m["name"]: _output_schema(m["type"]) for m in t["members"]}}
    if kind in ("sequence", "array"):
        return {"type": "array", "items": _output_schema(t["element"])}
    if kind == "optional":
        return {"anyOf": [{"type": "null"}, _output_schema(t["element"])]}
    return type_schema(t)


def _input_schema(service: Json) -> Json:
    params = [p for p in service["parameters"] if p["dir"] != "out"]
    properties = {}
    for p in params:
        schema = {**type_schema(p["type"]), "description": p.get("doc") or p["type"]["name"]}
        if "default" in p:
            schema["default"] = p["default"]
        properties[p["name"]] = schema
    return {"type": "object", "additionalProperties": False, "properties": properties}


def _status_schema(instance: str, info: Json, service: Json) -> Json:
    outs = [p for p in service["parameters"] if p["dir"] != "in"]
    output = {"type": "object", "properties": {p["name"]: _output_schema(p["type"]) for p in outs}}
    declared = {e["name"]: e for e in info.get("exceptions", [])}
    raised = [*service.get("throws", []), "::genom::interrupted"]
    exceptions = []
    for name in raised:
        detail = declared.get(name, {}).get("detail") or []
        schema: Json = {"type": "object", "required": ["ex"], "properties": {"ex": {"const": name}}}
        if detail:
            schema["properties"]["detail"] = {"type": "object", "properties": {
                d["name"]: _output_schema(d["type"]) for d in detail}}
        if declared.get(name, {}).get("doc"):
            schema["description"] = declared[name]["doc"]
        exceptions.append(schema)
    request_id = {"type": "string", "pattern": f"^{instance}::[0-9]+$"}
    return {"oneOf": [
        {"title": "running", "type": "object", "required": ["id", "status"],
         "properties": {"id": request_id, "status": {"const": "sent"}}},
        {"title": "done", "type": "object", "required": ["id", "status"],
         "properties": {"id": request_id, "status": {"const": "done"}, "output": output}},
        {"title": "error", "type": "object", "required": ["id", "status", "exception"],
         "properties": {"id": request_id, "status": {"const": "error"},
                        "exception": {"anyOf": [*exceptions, {"$ref": "#/components/schemas/Exception"}]}}},
    ]}


def _errors(*codes: int) -> Json:
    meaning = {400: "The input does not fit its type, or a query parameter is malformed",
               401: "The gateway needs its token", 403: "Refused to browsers of other sites",
               404: "No such module, service, port or request", 409: "The request is running, or the module stops",
               429: "Too many running activities, sessions or instances",
               503: "The gateway shuts down"}
    return {str(c): {"description": meaning[c], "content": {"application/json": {"schema": _ERROR}}} for c in codes}


def _service_path(instance: str, info: Json, service: Json) -> Json:
    doc = service.get("doc") or service["name"]
    return {"get": {
        "operationId": f"{instance}.{service['name']}",
        "tags": [instance],
        "summary": doc.splitlines()[0] if doc else service["name"],
        "description": f"{doc}\n\nA {service['kind']}"
                       + (f"; interrupts {', '.join(service['interrupts'])}" if service.get("interrupts") else "")
                       + (f"; may raise {', '.join(service['throws'])}" if service.get("throws") else "") + ".",
        "parameters": [
            {"name": "input", "in": "query", "required": False, "description": "The inputs, as a JSON object",
             "content": {"application/json": {"schema": _input_schema(service)}}},
            {"$ref": "#/components/parameters/session"},
            {"name": "oneway", "in": "query", "required": False, "allowEmptyValue": True,
             "description": "Nobody is told the result", "schema": {"type": "string"}},
        ],
        "responses": {
            "200": {"description": "The status object of the new request: `sent` for a running activity, "
                                   "`done` with its output, or `error` with the component's exception",
                    "content": {"application/json": {"schema": _status_schema(instance, info, service)}}},
            **_errors(400, 401, 404, 409, 429),
        },
    }}


def _get(summary: str, params: list[Json], responses: Json, tag: str = "gateway") -> Json:
    return {"get": {"summary": summary, "tags": [tag], "parameters": params, "responses": responses}}


def _path_param(name: str, description: str) -> Json:
    return {"name": name, "in": "path", "required": True, "description": description, "schema": {"type": "string"}}


def _json(description: str, schema: Json | None = None) -> Json:
    return {"description": description, "content": {"application/json": {"schema": schema or {}}}}


def _endpoints() -> Json:
    """The paths every gateway has (docs/protocol.md)."""
    session = {"$ref": "#/components/parameters/session"}
    module, rq = _path_param("module", "The instance"), _path_param("rqst", "A request id, M::n or n")
    status = _json("The status object", {"$ref": "#/components/schemas/Status"})
    stream = {"description": "Server-sent events (close-delimited)", "content": {"text/event-stream": {}}}
    name = _path_param("name", "A component (see /)")
    return {
        "/": _get("What runs here: versions, loaded modules, loadable components", [], {"200": _json("The index")}),
        "/version": _get("The genomix protocol version", [], {"200": {"description": "1.7.3", "content": _TEXT}}),
        "/openapi.json": _get("This document", [], {"200": _json("OpenAPI 3.1")}),
        "/console": _get("The browser console", [], {"200": {"description": "HTML",
                                                              "content": {"text/html": {}}}}),
        "/session/start": _get("Start (or reuse) a session", [session],
                               {"200": {"description": "The session name", "content": _TEXT}, **_errors(400, 429)},
                               "sessions"),
        "/session/stop": _get("Stop a session", [session], {"200": {"description": "Stopped"}, **_errors(400, 404)},
                              "sessions"),
        "/session/listen": _get("The session's events", [session], {"200": stream, **_errors(400)}, "sessions"),
        "/load/{name}": _get("Load a component", [name, {"name": "argv", "in": "query", "schema": {"type": "string"}}],
                             {"200": {"description": "The instance name", "content": _TEXT},
                              **_errors(400, 403, 404, 429)}),
        "/unload/{name}": _get("Unload an instance", [name], {"200": {"description": "The instance name",
                                                                      "content": _TEXT}, **_errors(404)}),
        "/usage/{name}": _get("A component's load options", [name], {"200": _json("Options"), **_errors(404)}),
        "/module/{module}/info": _get("The description of an instance", [module],
                                      {"200": _json("The /info description"), **_errors(404)}, "modules"),
        "/module/{module}/status/{rqst}": _get("A request's status", [module, rq], {"200": status, **_errors(404)},
                                               "modules"),
        "/module/{module}/wait/{rqst}": _get(
            "A request's status once it has ended (or after timeout seconds)",
            [module, rq, {"name": "timeout", "in": "query", "schema": {"type": "number", "minimum": 0}}],
            {"200": status, **_errors(400, 404, 503)}, "modules"),
        "/module/{module}/abort/{rqst}": _get("Interrupt a request", [module, rq], {"200": status, **_errors(404)},
                                              "modules"),
        "/module/{module}/clean/{rqst}": _get("Forget an ended request", [module, rq],
                                              {"200": {"description": "Forgotten"}, **_errors(404, 409)}, "modules"),
        "/module/{module}/read/{port}": _get(
            "Read a port", [module, _path_param("port", "The port"),
                            {"name": "name", "in": "query", "schema": {"type": "string"}},
                            {"name": "since", "in": "query", "schema": {"type": "integer", "minimum": 0}},
                            {"name": "format", "in": "query", "schema": {"enum": ["json", "binary"]}}],
            {"200": {"description": "{PORT: data}, or the binary form",
                     "content": {"application/json": {}, "application/x-aiogenomix-binary": {}}},
             **_errors(400, 404)}, "ports"),
        "/module/{module}/watch/{port}": _get(
            "Watch a port", [module, _path_param("port", "The port"),
                             {"name": "since", "in": "query", "schema": {"type": "integer", "minimum": 0}}],
            {"200": stream, **_errors(400, 404)}, "ports"),
    }


def openapi_document(infos: dict[str, Json], server: str, version: str) -> Json:
    """The OpenAPI 3.1 document of a gateway whose loaded instances have the ``/info`` descriptions *infos*.

    Args:
        infos: ``/info`` of every loaded instance, by instance name.
        server: The base URL clients use (``http://127.0.0.1:8080``).
        version: The gateway's version.
    """
    paths = _endpoints()
    for instance, info in infos.items():
        for service in info["services"]:
            paths[f"/module/{instance}/send/{service['name']}"] = _service_path(instance, info, service)
    return {
        "openapi": "3.1.0",
        "info": {"title": "aiogenomix gateway", "version": version,
                 "description": "The genomix HTTP/JSON protocol (docs/protocol.md): every request is a GET; "
                                "one path per service of every loaded module."},
        "servers": [{"url": server}],
        "tags": [{"name": instance, "description": info.get("doc", "")} for instance, info in infos.items()],
        "paths": paths,
        "components": {
            "parameters": {"session": {"name": "s", "in": "query", "required": False, "schema": {"type": "string"},
                                       "description": "The session whose listen stream gets the events"}},
            "schemas": {
                "Error": {"type": "object", "required": ["ex"], "properties": {
                    "ex": {"type": "string"}, "message": {"type": "string"}, "detail": {"type": "object"}}},
                "Exception": {"type": "object", "required": ["ex"], "properties": {
                    "ex": {"type": "string"}, "detail": {"type": "object"}}},
                "Status": {"type": "object", "required": ["id", "status"], "properties": {
                    "id": {"type": "string"}, "status": {"enum": ["sent", "done", "error"]},
                    "output": {"type": "object"}, "exception": {"$ref": "#/components/schemas/Exception"}}},
            },
            "securitySchemes": {"token": {"type": "http", "scheme": "bearer",
                                          "description": "When the gateway runs with --token"}},
        },
    }
