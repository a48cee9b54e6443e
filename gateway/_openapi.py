"""The OpenAPI 3.1 description of the gateway: its endpoints, and the services and ports of every loaded module.

Built from the same ``/info`` descriptions the clients read, so that users of
any language can generate a typed client or browse the gateway in their usual
tools (Swagger UI is served at ``/docs``).  What generators need, and get here:

* an ``operationId`` on every operation (``demo_GotoPosition``, ``demo_read_Mobile``, ``getStatus``...);
* named models in ``components/schemas``: every IDL struct (``demo_state``), each
  service's input and output (``demo_GotoPosition_Input``), its status object, and
  each out port's reply (``demo_read_Mobile_Reply``: ``{"Mobile": demo_state}``);
* a service's input as a typed JSON body of the ``POST`` form of ``send``
  (docs/decisions/0024); the genomix ``GET`` form keeps its ``input`` as a string
  of JSON text whose ``contentSchema`` is the same model;
* ``links`` from a send's request id to ``status``, ``wait``, ``abort`` and ``clean``;
* the token as the ``security`` of every operation but the console's, when the
  gateway has one.
"""

from __future__ import annotations

import re
from typing import Any

from ..components.core import JsonSchemas, schema_name
from ._routes_modules import MAX_WAIT
from ._sessions import MAX_NAME_LENGTH, NAME_FORBIDDEN

__all__ = ["openapi_document"]

Json = dict[str, Any]

_SCHEMAS = "#/components/schemas/"
_ERROR = {"$ref": _SCHEMAS + "Error"}
_TEXT = {"text/plain": {"schema": {"type": "string"}}}
#: A session name (``_sessions``).
_SESSION_NAME = {"type": "string", "maxLength": MAX_NAME_LENGTH, "pattern": f"^[^{NAME_FORBIDDEN}]*$"}
#: Paths served without the token (the console asks for it itself).
_OPEN = ("/console", "/console/auth", "/console/login", "/openapi.json", "/docs")
#: An identifier for generated code from parts (``::demo::state`` → ``demo_state``).
_name = schema_name


def _errors(*codes: int) -> Json:
    meaning = {400: "A query parameter the endpoint does not take, or one that is malformed, or an input that "
                    "does not fit its type",
               401: "The gateway needs its token", 403: "Refused to browsers of other sites",
               404: "No such module, service, port, request or session",
               409: "The request is running, or the module stops, or several component hosts offer the name "
                    "(::genomix::ambiguous_module: load NAME@HOST)", 415: "A body that is not JSON",
               429: "Too many running activities, sessions or instances, or a budget of all reached "
                    "(::genomix::over_budget)",
               502: "The component host offering the name speaks another remote protocol (::genomix::remote_protocol)",
               503: "The gateway shuts down, or the port's data is withdrawn (its sensor is down)",
               504: "The component host running the instance did not answer in time, or was not heard from within "
                    "the stale bound (::genom::remote_io)"}
    return {str(c): {"description": meaning[c], "content": {"application/json": {"schema": _ERROR}}} for c in codes}


def _service_operations(instance: str, info: Json, service: Json, schemas: JsonSchemas) -> Json:
    ident = _name(instance, service["name"])
    ins = [p for p in service["parameters"] if p["dir"] != "out"]
    outs = [p for p in service["parameters"] if p["dir"] != "in"]
    properties = {}
    for p in ins:
        schema = schemas.input(p["type"])
        schema = {"allOf": [schema]} if "$ref" in schema else dict(schema)
        schema["description"] = p.get("doc") or p["type"]["name"]
        if p.get("unit"):
            schema["x-unit"] = p["unit"]
        if "default" in p:
            schema["default"] = p["default"]
        properties[p["name"]] = schema
    # Wrappers are described, not titled: some generators name classes after titles, and these repeat.
    model = schemas.ref(f"{ident}_Input", {"type": "object", "additionalProperties": False, "properties": properties,
                                           "description": f"The inputs of {instance}.{service['name']}"})
    output = schemas.ref(f"{ident}_Output", {
        "type": "object", "description": f"The outputs of {instance}.{service['name']}",
        "required": [p["name"] for p in outs],
        "properties": {p["name"]: JsonSchemas.described(schemas.output(p["type"]), p) for p in outs}})
    status = schemas.ref(f"{ident}_Status", {
        "type": "object", "description": f"The status of a request of {instance}.{service['name']}",
        "required": ["id", "status"],
        "properties": {"id": {"type": "string", "pattern": f"^{re.escape(instance)}::[0-9]+$"},
                       "status": {"type": "string", "enum": ["sent", "done", "error"]},
                       "output": output, "exception": {"$ref": _SCHEMAS + "Exception"}}})
    declared = {e["name"]: e for e in info.get("exceptions", [])}
    raised = [*service.get("throws", []), "::genom::interrupted"]
    doc = service.get("doc") or service["name"]
    description = (f"{doc}\n\nA {service['kind']}"
                   + (f"; interrupts {', '.join(service['interrupts'])}" if service.get("interrupts") else "")
                   + ". Its request may end in `error` with "
                   + ", ".join(f"`{name}`" + (f" ({declared[name]['doc'].splitlines()[0]})"
                                              if declared.get(name, {}).get("doc") else "") for name in raised)
                   + ".")
    links = {verb: {"operationId": operation, "parameters": {"module": instance, "rqst": "$response.body#/id"},
                    "description": f"The {verb} of the request just sent"}
             for verb, operation in (("status", "getStatus"), ("wait", "waitRequest"), ("abort", "abortRequest"),
                                     ("clean", "cleanRequest"))}
    replies = {"200": {"description": "The status object of the new request: `sent` for a running activity, "
                                      "`done` with its output, or `error` with the component's exception",
                       "content": {"application/json": {"schema": status}}, "links": links},
               **_errors(400, 401, 404, 409, 429, 504)}
    common = {"tags": [instance], "summary": doc.splitlines()[0], "description": description}
    oneway = {"name": "oneway", "in": "query", "required": False, "allowEmptyValue": True,
              "description": "Nobody is told the result: no events, and the request is forgotten when it ends",
              "schema": {"type": "string"}}
    session = {"$ref": "#/components/parameters/session"}
    return {
        "post": {**common, "operationId": ident, "parameters": [session, oneway],
                 "requestBody": {"required": False, "description": "The inputs (defaults for those left out)",
                                 "content": {"application/json": {"schema": model}}},
                 "responses": {**replies, **_errors(415)}},
        "get": {**common, "operationId": f"{ident}_query",
                "summary": f"{common['summary']} (genomix form: the input as JSON text in the query)",
                "parameters": [{"name": "input", "in": "query", "required": False,
                                "description": "The inputs as JSON text (URL-encoded), e.g. `{\"posRef\":0.5}`",
                                "schema": {"type": "string", "contentMediaType": "application/json",
                                           "contentSchema": model}}, session, oneway],
                "responses": replies},
    }


def _port_operation(instance: str, port: Json, schemas: JsonSchemas) -> Json:
    ident = _name(instance, "read", port["name"])
    reply = schemas.ref(f"{ident}_Reply", {"type": "object", "description": f"A read of {instance}/{port['name']}",
                                           "required": [port["name"]],
                                           "properties": {port["name"]: schemas.output(port["type"])}})
    parameters: list[Json] = [{"name": "format", "in": "query", "required": False,
                               "description": "json (the default) or binary (docs/protocol.md)",
                               "schema": {"type": "string", "enum": ["json", "binary"]}}]
    if port.get("kind") == "multiple":
        parameters.append({"name": "name", "in": "query", "required": True, "description": "The element",
                           "schema": {"type": "string"}})
    doc = port.get("doc") or f"The port {port['name']}"
    return {"get": {"operationId": ident, "tags": [instance], "summary": f"Read {port['name']}: "
                    + doc.splitlines()[0], "description": doc, "parameters": parameters,
                    "responses": {"200": {"description": f"`{{\"{port['name']}\": data}}`",
                                          "content": {"application/json": {"schema": reply},
                                                      "application/x-aiogenomix-binary": {}}},
                                  **_errors(400, 401, 404, 429, 503, 504)}}}


def _get(operation: str, summary: str, params: list[Json], responses: Json, tag: str = "gateway") -> Json:
    return {"get": {"operationId": operation, "summary": summary, "tags": [tag], "parameters": params,
                    "responses": {**responses, **({} if "400" in responses else _errors(400))}}}


def _path_param(name: str, description: str) -> Json:
    return {"name": name, "in": "path", "required": True, "description": description, "schema": {"type": "string"}}


def _json(description: str, schema: Json | None = None) -> Json:
    return {"description": description, "content": {"application/json": {"schema": schema or {"type": "object"}}}}


def _endpoints() -> Json:
    """The paths every gateway has (docs/protocol.md)."""
    session = {"$ref": "#/components/parameters/session"}
    named = {"name": "s", "in": "query", "required": True, "description": "The session",
             "schema": {**_SESSION_NAME, "minLength": 1}}
    module, rq = _path_param("module", "The instance"), _path_param("rqst", "A request id, M::n or n")
    status = _json("The status object", {"$ref": _SCHEMAS + "Status"})
    stream = {"description": "Server-sent events: close-delimited, or chunked with ids for `Accept: "
                             "text/event-stream`", "content": {"text/event-stream": {"schema": {"type": "string"}}}}
    name = _path_param("name", "A component (see /)")
    html = {"description": "HTML", "content": {"text/html": {"schema": {"type": "string"}}}}
    return {
        "/": _get("getIndex", "What runs here: versions, loaded modules, loadable components", [],
                  {"200": _json("The index")}),
        "/version": _get("getVersion", "The genomix protocol version", [],
                         {"200": {"description": "1.7.3", "content": _TEXT}}),
        "/openapi.json": _get("getOpenapi", "This document", [], {"200": _json("OpenAPI 3.1")}),
        "/docs": _get("getDocs", "This document in Swagger UI", [], {"200": html}),
        "/console": _get("getConsole", "The browser console", [], {"200": html}),
        "/console/auth": _get("consoleAuth", "Whether this request carries the token or the console's cookie", [],
                              {"200": _json("`{\"authorized\": bool}`")}),
        "/console/login": _get("consoleLogin", "Trade the token for the console's cookie", [],
                               {"204": {"description": "The cookie is set"}, **_errors(401)}),
        "/session/start": _get("startSession", "Start (or reuse) a session; an empty name picks one", [session],
                               {"200": {"description": "The session name", "content": _TEXT}, **_errors(400, 429)},
                               "sessions"),
        "/session/stop": _get("stopSession", "Stop a session", [named],
                              {"200": {"description": "Stopped"}, **_errors(400, 404)}, "sessions"),
        "/session/listen": _get("listenSession", "The session's events", [named],
                                {"200": stream, "204": {"description": "A reconnect after quit"}, **_errors(400)},
                                "sessions"),
        "/load/{name}": _get("loadComponent", "Load a component",
                             [name, {"name": "argv", "in": "query", "required": False,
                                     "description": "Load options, such as `-i INSTANCE`",
                                     "schema": {"type": "string"}}],
                             {"200": {"description": "The instance name", "content": _TEXT},
                              **_errors(400, 403, 404, 409, 429, 502, 504)}),
        "/unload/{name}": _get("unloadInstance", "Unload an instance", [name],
                               {"200": {"description": "The instance name", "content": _TEXT}, **_errors(404)}),
        "/usage/{name}": _get("getUsage", "A component's load options", [name],
                              {"200": _json("Options", {"type": "array", "items": {"type": "object"}}),
                               **_errors(404)}),
        "/module/{module}/info": _get("getInfo", "The description of an instance", [module],
                                      {"200": _json("The /info description"), **_errors(404)}, "modules"),
        "/module/{module}/status/{rqst}": _get("getStatus", "A request's status", [module, rq],
                                               {"200": status, **_errors(404, 504)}, "modules"),
        "/module/{module}/wait/{rqst}": _get(
            "waitRequest", "A request's status once it has ended (or after timeout seconds)",
            [module, rq, {"name": "timeout", "in": "query", "required": False,
                          "description": f"Seconds to wait at most (default and most: {MAX_WAIT:g})",
                          "schema": {"type": "number", "minimum": 0, "maximum": MAX_WAIT}}],
            {"200": status, **_errors(400, 404, 503)}, "modules"),
        "/module/{module}/abort/{rqst}": _get("abortRequest", "Interrupt a request", [module, rq],
                                              {"200": status, **_errors(404, 504)}, "modules"),
        "/module/{module}/clean/{rqst}": _get("cleanRequest", "Forget an ended request", [module, rq],
                                              {"200": {"description": "Forgotten"}, **_errors(404, 409, 504)},
                                              "modules"),
        "/module/{module}/read/{port}": _get(
            "readPort", "Read a port (each loaded module's ports also have a typed path of their own)",
            [module, _path_param("port", "The port"),
             {"name": "name", "in": "query", "required": False, "description": "The element of a multiple port",
              "schema": {"type": "string"}},
             {"name": "since", "in": "query", "required": False, "description": "Only the items after this one",
              "schema": {"type": "integer", "minimum": 0}},
             {"name": "format", "in": "query", "required": False, "description": "json (the default) or binary",
              "schema": {"type": "string", "enum": ["json", "binary"]}}],
            {"200": {"description": "{PORT: data}, or the binary form",
                     "content": {"application/json": {"schema": {"type": "object"}},
                                 "application/x-aiogenomix-binary": {}}},
             **_errors(400, 404, 429, 503, 504)}, "ports"),
        "/module/{module}/watch/{port}": _get(
            "watchPort", "Watch a port",
            [module, _path_param("port", "The port"),
             {"name": "name", "in": "query", "required": False, "description": "The element of a multiple port",
              "schema": {"type": "string"}},
             {"name": "since", "in": "query", "required": False, "description": "Only the items after this one",
              "schema": {"type": "integer", "minimum": 0}}],
            {"200": stream, "204": {"description": "A reconnect after unload"}, **_errors(400, 404, 429, 503, 504)},
            "ports"),
    }


def openapi_document(infos: dict[str, Json], server: str, version: str, token: bool = False) -> Json:
    """The OpenAPI 3.1 document of a gateway whose loaded instances have the ``/info`` descriptions *infos*.

    Args:
        infos: ``/info`` of every loaded instance, by instance name.
        server: The base URL clients use (``http://127.0.0.1:8080``).
        version: The gateway's version.
        token: Whether the gateway needs its token (every operation but the console's says so).
    """
    schemas = JsonSchemas(_SCHEMAS)
    paths = _endpoints()
    for instance, info in infos.items():
        for service in info["services"]:
            paths[f"/module/{instance}/send/{service['name']}"] = _service_operations(instance, info, service,
                                                                                        schemas)
        for port in info.get("ports", []):
            if port.get("dir") == "out":
                paths[f"/module/{instance}/read/{port['name']}"] = _port_operation(instance, port, schemas)
    for path in _OPEN:
        paths[path]["get"]["security"] = []
    return {
        "openapi": "3.1.0",
        "info": {"title": "aiogenomix gateway", "version": version,
                 "license": {"name": "BSD-2-Clause", "identifier": "BSD-2-Clause"},
                 "description": "The genomix HTTP/JSON protocol (docs/protocol.md): every service of every loaded "
                                "module, as a POST with a typed JSON body or as genomix's GET, and every out port."},
        "servers": [{"url": server}],
        "security": [{"token": []}] if token else [{}],
        "tags": [{"name": "gateway", "description": "The gateway itself"},
                 {"name": "sessions", "description": "Sessions and their events"},
                 {"name": "modules", "description": "Requests of any module"},
                 {"name": "ports", "description": "Ports of any module"},
                 *({"name": instance, "description": info.get("doc") or instance} for instance, info in infos.items())],
        "paths": paths,
        "components": {
            "parameters": {"session": {"name": "s", "in": "query", "required": False, "schema": _SESSION_NAME,
                                       "description": "The session whose listen stream gets the events"}},
            "schemas": {
                "Error": {"type": "object", "required": ["ex"], "properties": {
                    "ex": {"type": "string"}, "message": {"type": "string"}, "detail": {"type": "object"}}},
                "Exception": {"type": "object", "required": ["ex"], "properties": {
                    "ex": {"type": "string"}, "detail": {"type": "object"}}},
                "Status": {"type": "object", "required": ["id", "status"], "properties": {
                    "id": {"type": "string"}, "status": {"type": "string", "enum": ["sent", "done", "error"]},
                    "output": {"type": "object"}, "exception": {"$ref": _SCHEMAS + "Exception"}}},
                **schemas.named,
            },
            "securitySchemes": {"token": {"type": "http", "scheme": "bearer",
                                          "description": "The gateway's --token"}},
        },
    }
