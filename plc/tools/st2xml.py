"""Generates the PLCopen XML (IEC 61131-10 / TC6 XML 2.01) export of the
library from its ST, for import into CODESYS and TwinCAT 3:
plc/xml/HansRobot.xml (the library: plc/src), plc/xml/PickAndPlace.xml
(the example program) and one file per adapter of those two platforms
(HansCodesysAdapter.xml, HansTwinCatAdapter.xml). Usage: st2xml.py [--check]
(--check: exit 1 when a committed file differs from the output).

The declarations come from blark's parse tree (names, sections, types,
initial values as written in the source, the comments as documentation);
each body is the ST text after the declarations, unchanged, in an
<ST><xhtml> element as CODESYS and TwinCAT write it in their own exports.
What the export does not carry, it refuses with an error naming it
(pointers, inline arrays, structured initial values, ...): they are outside
the library's subset anyway. The output is byte for byte reproducible (the
creation time is fixed; see FILE_HEADER)."""

from __future__ import annotations

import re
import sys
from pathlib import Path

from lxml import etree

import stinterp
from blark import transform as tf

PLC = Path(__file__).resolve().parent.parent
LIBRARY = [PLC / "src" / "HansTypes.st", PLC / "src" / "HansCore.st", PLC / "src" / "HansBlocks.st"]
EXAMPLE = [PLC / "examples" / "PickAndPlace.st"]
OUTPUTS = {
    PLC / "xml" / "HansRobot.xml": (LIBRARY, "hans-tcp PLC library (SRCI / PLCopen Part 4 names)"),
    PLC / "xml" / "PickAndPlace.xml": (EXAMPLE, "hans-tcp PLC library: the pick-and-place example (import the library first)"),
    PLC / "xml" / "HansCodesysAdapter.xml": ([PLC / "adapters" / "CodesysAdapter.st"],
                                             "hans-tcp PLC library: the CODESYS adapter (import the library first)"),
    PLC / "xml" / "HansTwinCatAdapter.xml": ([PLC / "adapters" / "TwinCatAdapter.st"],
                                             "hans-tcp PLC library: the TwinCAT 3 adapter (import the library first; "
                                             "needs Tc2_ModbusSrv)"),
}

TC6 = "http://www.plcopen.org/xml/tc6_0201"
XHTML = "http://www.w3.org/1999/xhtml"

# A fixed creation time: the file is compared byte for byte with this
# script's output, so nothing in it may change from run to run. The
# content's version is contentHeader/@version.
FILE_HEADER = {
    "companyName": "hans-tcp",
    "productName": "hans-tcp PLC library",
    "productVersion": "1.4",
    "creationDateTime": "2026-11-29T00:00:00",
}
# The register map the library is written for (map 1.4: thousandths).
CONTENT_VERSION = "1.4"

ELEMENTARY = {
    "BOOL", "BYTE", "WORD", "DWORD", "LWORD", "SINT", "INT", "DINT", "LINT", "USINT", "UINT", "UDINT",
    "ULINT", "REAL", "LREAL", "TIME", "DATE", "DT", "TOD",
}

# blark's declaration blocks -> the TC6 interface's element.
SECTIONS = {
    tf.InputDeclarations: "inputVars",
    tf.OutputDeclarations: "outputVars",
    tf.InputOutputDeclarations: "inOutVars",
    tf.VariableDeclarations: "localVars",
    tf.FunctionVariableDeclarations: "localVars",
    tf.LocatedVariableDeclarations: "localVars",
    tf.TemporaryVariableDeclarations: "tempVars",
}


class ExportError(Exception):
    """The source has something this export does not carry."""


def el(parent, tag, ns=TC6, **attrs):
    e = etree.SubElement(parent, f"{{{ns}}}{tag}")
    for k, v in attrs.items():
        e.set(k, str(v))
    return e


def xhtml(parent, tag: str, text: str):
    """A formattedText element: one XHTML <xhtml> element holding the text."""
    holder = el(parent, tag)
    x = etree.SubElement(holder, f"{{{XHTML}}}xhtml", nsmap={None: XHTML})
    x.text = text
    return holder


def comment_text(tokens) -> str:
    """The text of (* ... *) comments, each line stripped, lines kept."""
    out = []
    for t in tokens:
        s = str(t)
        s = s[2:-2] if s.startswith("(*") and s.endswith("*)") else s
        out.append("\n".join(line.strip() for line in s.strip().splitlines()))
    return "\n".join(out).strip()


def source(chunk: str, node) -> str:
    """The source text of a parsed node (its literal value as written)."""
    meta = getattr(node, "meta", None)
    if meta is None or meta.start_pos is None:
        return str(node)
    return chunk[meta.start_pos:meta.end_pos]


def type_element(parent, spec, where: str):
    """<type>'s content for a blark type specification."""
    if isinstance(spec, tf.IndirectSimpleSpecification):
        if spec.indirection is not None or spec.init_parameters:
            raise ExportError(f"{where}: pointer/reference type")
        spec = spec.type
    if isinstance(spec, tf.SimpleSpecification):
        spec = spec.type
    if isinstance(spec, tf.DataType):
        if spec.indirection is not None:
            raise ExportError(f"{where}: pointer/reference type")
        spec = spec.type_name
    if isinstance(spec, tf.StringTypeSpecification):
        kind = "wstring" if str(spec.type_name).upper() == "WSTRING" else "string"
        e = el(parent, kind)
        if spec.length is not None:
            e.set("length", str(spec.length.length).strip("()[] "))
        return e
    if not isinstance(spec, str):
        raise ExportError(f"{where}: type {type(spec).__name__} ({spec}) is not exported")
    name = str(spec)
    up = name.upper()
    if up in ELEMENTARY:
        return el(parent, up)
    if up in ("STRING", "WSTRING"):
        return el(parent, up.lower())
    return el(parent, "derived", name=name)


def add_variable(parent, decl, chunk: str, where: str):
    """One <variable> per declared name of a declaration."""
    if isinstance(decl, tf.LocatedVariableDeclaration):
        names = [(str(decl.name.name), str(decl.location))]
    elif isinstance(decl, (tf.VariableOneInitDeclaration, tf.StructureElementDeclaration)):
        names = [(str(v.variable.name), str(v.location) if v.location else None) for v in decl.variables]
    else:
        raise ExportError(f"{where}: declaration {type(decl).__name__} ({decl}) is not exported")
    init = decl.init
    if not isinstance(init, tf.TypeInitialization):
        raise ExportError(f"{where}: {type(init).__name__} ({init}) is not exported (name a type)")
    for name, address in names:
        v = el(parent, "variable", name=name)
        if address:
            v.set("address", address.replace("AT ", "").strip())
        type_element(el(v, "type"), init.spec, f"{where}.{name}")
        if init.value is not None:
            if isinstance(init.value, (tf.ArrayInitialization, tf.StructureInitialization)):
                raise ExportError(f"{where}.{name}: structured initial value")
            el(el(v, "initialValue"), "simpleValue", value=source(chunk, init.value))
        doc = comment_text(decl.meta.comments if decl.meta else [])
        if doc:
            xhtml(v, "documentation", doc)


def add_data_type(types, item, chunk: str, doc: str):
    d = item.declaration
    name = str(d.name)
    dt = el(types, "dataType", name=name)
    base = el(dt, "baseType")
    if isinstance(d, tf.StructureTypeDeclaration):
        if d.extends is not None:
            raise ExportError(f"{name}: EXTENDS")
        s = el(base, "struct")
        for m in d.declarations:
            add_variable(s, m, chunk, name)
    elif isinstance(d, tf.ArrayTypeDeclaration):
        spec = d.init.spec
        a = el(base, "array")
        for r in spec.subranges:
            el(a, "dimension", lower=str(r.start), upper=str(r.stop))
        type_element(el(a, "baseType"), spec.type, name)
        if d.init.value is not None:
            raise ExportError(f"{name}: array initial value")
    elif isinstance(d, tf.EnumeratedTypeDeclaration):
        e = el(base, "enum")
        values = el(e, "values")
        for v in d.init.spec.values:
            val = el(values, "value", name=str(v.name))
            if v.value is not None:
                val.set("value", str(v.value))
        if d.init.value is not None:
            el(el(dt, "initialValue"), "simpleValue", value=source(chunk, d.init.value))
    else:
        raise ExportError(f"{name}: type declaration {type(d).__name__} is not exported")
    if doc:
        xhtml(dt, "documentation", doc)


POU_TYPES = {tf.Function: "function", tf.FunctionBlock: "functionBlock", tf.Program: "program"}
END = {tf.Function: "END_FUNCTION", tf.FunctionBlock: "END_FUNCTION_BLOCK", tf.Program: "END_PROGRAM"}


def add_pou(pous, item, chunk: str, doc: str):
    name = str(item.name)
    kind = type(item)
    pou = el(pous, "pou", name=name, pouType=POU_TYPES[kind])
    interface = el(pou, "interface")
    if kind is tf.Function:
        type_element(el(interface, "returnType"), item.return_type, name)
    decls = list(item.declarations)
    for block in decls:
        section = SECTIONS.get(type(block))
        if section is None:
            raise ExportError(f"{name}: {type(block).__name__} is not exported")
        vl = el(interface, section)
        attrs = block.attrs if hasattr(block, "attrs") else None
        if attrs:
            for flag in ("constant", "retain", "persistent"):
                if getattr(tf.VariableAttributes, flag) in attrs:
                    vl.set(flag, "true")
        for decl in block.items:
            add_variable(vl, decl, chunk, name)
    # The body: what follows the last END_VAR, up to the POU's END_ line.
    start = decls[-1].meta.end_pos if decls else chunk.index(name) + len(name)
    end = chunk.rindex(END[kind])
    body = chunk[start:end].strip("\n")
    body = "\n".join(line.rstrip() for line in body.splitlines()).strip("\n") + "\n"
    xhtml(el(pou, "body"), "ST", body)
    if doc:
        xhtml(pou, "documentation", doc)


def generate(sources, description: str) -> bytes:
    root = etree.Element(f"{{{TC6}}}project", nsmap={None: TC6})
    el(root, "fileHeader", **FILE_HEADER, contentDescription=description)
    ch = el(root, "contentHeader", name=FILE_HEADER["productName"], version=CONTENT_VERSION)
    el(ch, "Comment").text = ("GENERATED by plc/tools/st2xml.py from "
                              + ", ".join(str(p.relative_to(PLC)) for p in sources)
                              + ": do not edit; edit the ST and regenerate.")
    coords = el(ch, "coordinateInfo")
    for lang in ("fbd", "ld", "sfc"):
        el(el(coords, lang), "scaling", x=1, y=1)
    types = el(root, "types")
    data_types = el(types, "dataTypes")
    pous = el(types, "pous")
    file_docs = []
    for path in sources:
        first = True
        for _, chunk, items in stinterp.parsed_chunks(path):
            for item in items:
                comments = list(item.meta.comments) if item.meta else []
                if first and len(comments) > 1:
                    # The file's own header comment: the project's documentation.
                    file_docs.append(comment_text(comments[:1]))
                    comments = comments[1:]
                first = False
                doc = comment_text(comments[-1:])
                if isinstance(item, tf.DataTypeDeclaration):
                    add_data_type(data_types, item, chunk, doc)
                elif type(item) in POU_TYPES:
                    add_pou(pous, item, chunk, doc)
                else:
                    raise ExportError(f"{path}: top-level {type(item).__name__} is not exported")
    el(el(root, "instances"), "configurations")
    if file_docs:
        xhtml(root, "documentation", "\n".join(file_docs))
    return b'<?xml version="1.0" encoding="utf-8"?>\n' + etree.tostring(root, encoding="UTF-8", pretty_print=True)


def outputs() -> dict:
    """Every output file and the bytes the generator makes for it."""
    return {out: generate(srcs, desc) for out, (srcs, desc) in OUTPUTS.items()}


def main(argv):
    bad = 0
    for out, data in outputs().items():
        if "--check" in argv:
            if not out.exists() or out.read_bytes() != data:
                print(f"{out} is not the generator's output: run plc/tools/st2xml.py")
                bad += 1
        else:
            out.parent.mkdir(exist_ok=True)
            out.write_bytes(data)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
