"""Write a module's generated functions to a ``.py`` file (and a ``.pyi`` stub) for IDE completion and typing.

The MATLAB bridge wrote ``GMB_demo_GotoPosition.m`` onto the MATLAB path; this
writes ``demo_client.py`` whose functions have the same signatures, docstrings
and exceptions as the live ones, and forward to a connected client::

    python -m aiogenomix.clients.codegen --url localhost:8080 demo -o demo_client.py --pyi

    import demo_client
    demo_client.bind("localhost:8080")      # or bind(an open Client)
    demo_client.GotoPosition(0.5)
"""

from __future__ import annotations

import argparse
import json
import pathlib
import sys
import textwrap
import urllib.error
import urllib.request
from collections.abc import Sequence
from typing import Any

from ._errors import short_name
from ._module import ModuleDescription
from ._service import CONTROL_OPTIONS, PortSpec, ServiceSpec
from ._types import annotation_source
from ._wire import ExceptionInfo, ModuleInfo, base_url, check_info

__all__ = ["fetch_info", "generate_source", "generate_stub", "main"]

_HEADER_IMPORTS = """\
from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Callable, Literal, Optional

import numpy

from aiogenomix.clients import (
    USE_CLIENT_DEFAULT, Client, Forbidden, HostUnreachable, Interrupted, InvalidInput, Module, NotFound, Record,
    RemoteError, Request, TooManyActivities, connect, remote_exception_class,
)
"""


def _docstring(text: str, indent: str) -> str:
    body = text.replace("\\", "\\\\").replace('"""', '\\"\\"\\"')
    return textwrap.indent(f'"""{body}\n"""', indent).lstrip(" ") if "\n" in body else f'"""{body}"""'


def _default_source(value: Any) -> str:
    # /info defaults are JSON data, which Python reads back as literals (NaN travels as null).
    return repr(value)


def _service_params(spec: ServiceSpec, stub: bool) -> tuple[str, list[str]]:
    params, forwarded = [], []
    seen_default = False
    for p in spec.inputs:
        ann = spec.input_source(p)
        if "default" in p.info:
            seen_default = True
            default = "..." if stub else _default_source(p.info["default"])
            params.append(f"{p.pyname}: {ann} = {default}")
        elif seen_default:
            params.append(f"{p.pyname}: {ann} = {'...' if stub else '_UNSET'}")
        else:
            params.append(f"{p.pyname}: {ann}")
        forwarded.append(f"{p.name!r}: {p.pyname}")
    params.append("*")
    for opt, (ann, default, _) in CONTROL_OPTIONS.items():
        name = spec.options[opt]
        shown = "..." if stub else ("USE_CLIENT_DEFAULT" if opt == "timeout" else repr(default))
        params.append(f"{name}: {ann} = {shown}")
    return ", ".join(params), forwarded


def _service_source(spec: ServiceSpec) -> str:
    params, forwarded = _service_params(spec, stub=False)
    options = ", ".join(f"{spec.options[o]}={spec.options[o]}" for o in CONTROL_OPTIONS)
    return (f"def {spec.pyname}({params}) -> {spec.return_source} | Request:\n"
            f"    {_docstring(spec.doc, '    ')}\n"
            f"    return _target().{spec.pyname}(_inputs({{{', '.join(forwarded)}}}), {options})\n")


def _port_source(port: PortSpec, stub: bool) -> str:
    params = "name: str, *, " if port.multiple else "*, "
    params += "raw: bool = ..., timeout: Optional[float] = ..." if stub else (
        "raw: bool = False, timeout: Optional[float] = USE_CLIENT_DEFAULT")
    head = f"def {port.pyname}({params}) -> {port.return_source}:"
    if stub:
        return f"{head}\n    {_docstring(port.doc, '    ')}\n    ...\n"
    call = "name, raw=raw, timeout=timeout" if port.multiple else "raw=raw, timeout=timeout"
    return f"{head}\n    {_docstring(port.doc, '    ')}\n    return _target().{port.pyname}({call})\n"


def _exception_lines(description: ModuleDescription, stub: bool) -> list[str]:
    lines = []
    declared: dict[str, ExceptionInfo] = {e["name"]: e for e in description.info.get("exceptions", [])}
    taken = set(description.services) | set(description.ports)
    for name, cls in description.exceptions.items():
        if name in taken:
            continue
        ex = cls.ex or name
        generated = short_name(ex) == cls.__name__ and cls.__module__ == "aiogenomix.clients.remote"
        if not generated:
            lines.append(f"{name} = {cls.__name__}")
        elif stub:
            members = [f"    {m['name']}: {annotation_source(m['type'], 'out')}"
                       for m in (declared[ex]["detail"] if ex in declared else [])]
            lines.append(f"class {name}(RemoteError):\n    {_docstring(cls.__doc__ or '', '    ')}\n"
                         + ("\n".join(members) + "\n" if members else ""))
        else:
            doc, detail = (declared[ex].get("doc"), declared[ex].get("detail", [])) if ex in declared else (None, [])
            lines.append(f"{name} = remote_exception_class({ex!r}, {doc!r}, {detail!r})")
    return lines


def generate_source(info: ModuleInfo, source: str = "") -> str:
    """The ``.py`` file of a module: functions forwarding to a bound client, and the exception classes."""
    d = ModuleDescription(check_info(info))
    origin = f" from {source}" if source else ""
    parts = [
        f'"""Functions of the genomix module {d.instance} (component {d.component} {info.get("version", "")}).\n\n'
        f"Generated by aiogenomix.clients.codegen{origin} (revision {info.get('revision', '?')});\n"
        "regenerate it when the component changes. Call ``bind(client_or_address)`` first.\n\"\"\"\n",
        _HEADER_IMPORTS,
        f"INSTANCE = {d.instance!r}\nCOMPONENT = {d.component!r}\n",
        "_module: Module | None = None\n_UNSET: Any = object()\n",
        "\ndef bind(client: Client | str | None = None, instance: str = INSTANCE) -> Module:\n"
        '    """Forward this file\'s functions to *client* (or connect to an address); load the instance."""\n'
        "    global _module\n"
        "    if not isinstance(client, Client):\n        client = connect(client)\n"
        "    argv = () if instance == COMPONENT else ('-i', instance)\n"
        "    _module = client.load(COMPONENT, *argv)\n    return _module\n",
        "\ndef _target() -> Module:\n    if _module is None:\n"
        "        raise RuntimeError('call bind(client) of this generated file before using its functions')\n"
        "    return _module\n",
        "\ndef _inputs(given: dict[str, Any]) -> dict[str, Any]:\n"
        "    return {k: v for k, v in given.items() if v is not _UNSET}\n",
        "\n" + "\n".join(_exception_lines(d, stub=False)) + "\n",
    ]
    parts += ["\n" + _service_source(s) for s in d.services.values()]
    parts += ["\n" + _port_source(p, stub=False) for p in d.ports.values() if p.pyname not in d.services]
    names = ["bind", "INSTANCE", "COMPONENT"] + list(d.services) + [p for p in d.ports if p not in d.services]
    names += [n for n in d.exceptions if n not in d.services and n not in d.ports]
    parts.append(f"\n__all__ = {names!r}\n")
    return "\n".join(parts)


def generate_stub(info: ModuleInfo, source: str = "") -> str:
    """The ``.pyi`` stub: overloads tell type checkers that ``ack=True`` returns a Request."""
    d = ModuleDescription(check_info(info))
    parts = [f'"""Type stub of the genomix module {d.instance}; generated by aiogenomix.clients.codegen."""\n',
             _HEADER_IMPORTS.replace("from __future__ import annotations\n\n", "")
             .replace("from typing import Any, Callable, Literal, Optional",
                      "from typing import Any, Callable, Literal, Optional, overload"),
             "INSTANCE: str\nCOMPONENT: str\n\ndef bind(client: Client | str | None = ..., "
             "instance: str = ...) -> Module: ...\n"]
    parts += ["\n" + line for line in _exception_lines(d, stub=True)]
    for s in d.services.values():
        params, _ = _service_params(s, stub=True)
        ack = f"{s.options['ack']}: bool = ..."
        blocking = params.replace(ack, f"{s.options['ack']}: Literal[False] = ...")
        acked = params.replace(ack, f"{s.options['ack']}: Literal[True]")
        doc = _docstring(s.doc, "    ")
        parts.append(f"\n@overload\ndef {s.pyname}({blocking}) -> {s.return_source}:\n    {doc}\n    ...\n"
                     f"@overload\ndef {s.pyname}({acked}) -> Request: ...\n")
    parts += ["\n" + _port_source(p, stub=True) for p in d.ports.values() if p.pyname not in d.services]
    return "\n".join(parts)


def fetch_info(address: str, instance: str, *, load: bool = False, token: str | None = None,
               timeout: float = 30.0) -> ModuleInfo:
    """GET ``/module/INSTANCE/info`` (after ``/load/INSTANCE`` with *load*) without opening a session."""
    base = base_url(address)
    headers = {"Authorization": f"Bearer {token}"} if token else {}

    def get(path: str) -> bytes:
        with urllib.request.urlopen(urllib.request.Request(base + path, headers=headers), timeout=timeout) as r:
            body: bytes = r.read()
            return body

    if load:
        get(f"/load/{instance}")
    return check_info(json.loads(get(f"/module/{instance}/info")))


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: ``python -m aiogenomix.clients.codegen --url HOST:PORT MODULE [-o FILE.py] [--pyi]``."""
    parser = argparse.ArgumentParser(prog="python -m aiogenomix.clients.codegen", description=__doc__.split("\n")[0])
    parser.add_argument("module", help="the instance name (e.g. demo)")
    parser.add_argument("--url", default=None, help="the gateway, host:port (default localhost:8080)")
    parser.add_argument("-o", "--output", help="the .py file to write (default: MODULE_client.py); "
                                               "a .pyi name writes the stub only")
    parser.add_argument("--pyi", action="store_true", help="also write the .pyi stub next to the .py")
    parser.add_argument("--load", action="store_true", help="load the component first if needed")
    parser.add_argument("--token", default=None, help="bearer token of a gateway started with --token")
    args = parser.parse_args(argv)
    try:
        info = fetch_info(args.url, args.module, load=args.load, token=args.token)
    except (urllib.error.URLError, OSError, ValueError) as exc:
        print(f"cannot read /module/{args.module}/info from {base_url(args.url)}: {exc}", file=sys.stderr)
        return 1
    source = base_url(args.url)
    out = pathlib.Path(args.output or f"{args.module}_client.py")
    written = []
    if out.suffix == ".pyi":
        out.write_text(generate_stub(info, source), encoding="utf-8")
        written.append(out)
    else:
        out.write_text(generate_source(info, source), encoding="utf-8")
        written.append(out)
        if args.pyi:
            stub = out.with_suffix(".pyi")
            stub.write_text(generate_stub(info, source), encoding="utf-8")
            written.append(stub)
    print("wrote " + ", ".join(str(p) for p in written))
    return 0


if __name__ == "__main__":
    sys.exit(main())
