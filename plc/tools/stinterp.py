"""A small IEC 61131-3 Structured Text interpreter over blark's parse tree.

It runs the library's ST scan by scan for the tests (plc/tests). It covers
what the library and the example use, with IEC semantics, and refuses
anything else with an error naming the construct (so a library change that
leaves the subset fails loudly, not silently):

* POUs: FUNCTION (with VAR_INPUT, VAR_IN_OUT, VAR), FUNCTION_BLOCK (VAR_INPUT,
  VAR_OUTPUT, VAR_IN_OUT, VAR; instances keep their state between calls),
  PROGRAM (as a function block instance; its located variables only when
  the caller asks, as plain variables with their addresses recorded).
* Types: BOOL, SINT/INT/DINT/LINT, USINT/UINT/UDINT/ULINT, BYTE/WORD/DWORD,
  REAL/LREAL, TIME, STRING(n); named array types and inline arrays with one
  subrange; structures; enumerations (values by name, first by default);
  aliases of elementary types (TYPE HW_ANY : UINT; END_TYPE).
  Integers wrap to their type's width when stored (two's complement for the
  signed ones), REAL is rounded to IEEE single precision when stored.
* Standard blocks: R_TRIG, F_TRIG (the standard's bodies, so F_TRIG with
  M = FALSE at start), TON (time from the clock the caller gives); a
  platform's own blocks as Python objects the caller gives (Native: e.g.
  the tests' emulation of Siemens MB_CLIENT).
* Standard functions: the *_TO_* conversions between the types above
  (REAL to integer rounds to nearest, ties away from zero), SHL, SHR, MID,
  CONCAT, LEN, ABS, MIN, MAX.
* Statements: assignment, IF/ELSIF/ELSE, CASE (values, lists, ranges, ELSE),
  FOR (BY), WHILE, REPEAT, RETURN, EXIT, calls of FB instances and functions
  with formal (named) arguments; FB outputs read as instance.output.
* Expressions: + - * / MOD (integer division truncates toward zero),
  comparisons, AND OR XOR NOT (logical on BOOL, bitwise on bit strings and
  integers, NOT within the operand's width), unary minus, parentheses,
  literals (decimal, 16#/8#/2#, typed WORD#1, REAL, TRUE/FALSE, T#, strings
  with $ escapes).
* Calls: inputs are copied, VAR_IN_OUT is bound by reference, an FB's inputs
  not given in a call keep their last value (IEC), a function's locals start
  from their initial values at every call.
"""

from __future__ import annotations

import copy
import re
import os
import dataclasses
import math
import struct

from blark import parse as blark_parse
from blark import transform as tf


class StError(Exception):
    """The source uses something this interpreter does not run."""


INT_TYPES = {
    "SINT": (8, True), "INT": (16, True), "DINT": (32, True), "LINT": (64, True),
    "USINT": (8, False), "UINT": (16, False), "UDINT": (32, False), "ULINT": (64, False),
    "BYTE": (8, False), "WORD": (16, False), "DWORD": (32, False), "LWORD": (64, False),
}
REAL_TYPES = {"REAL", "LREAL"}


def wrap(v: int, tname: str) -> int:
    bits, signed = INT_TYPES[tname]
    v &= (1 << bits) - 1
    if signed and v >= 1 << (bits - 1):
        v -= 1 << bits
    return v


def f32(x: float) -> float:
    if math.isnan(x) or math.isinf(x):
        return x
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)


def round_away(x: float) -> int:
    return int(math.floor(x + 0.5)) if x >= 0 else -int(math.floor(-x + 0.5))


@dataclasses.dataclass
class Type:
    kind: str                      # 'int', 'real', 'bool', 'time', 'string', 'array', 'struct', 'enum', 'fb'
    name: str = ""
    lo: int = 0
    hi: int = 0
    elem: "Type | None" = None
    fields: dict = dataclasses.field(default_factory=dict)   # struct: name -> (Type, init expr)
    values: list = dataclasses.field(default_factory=list)   # enum
    length: int = 254


class Ref:
    """A reference to a storage place: a container (dict or list) and a key."""

    __slots__ = ("box", "key")

    def __init__(self, box, key):
        self.box = box
        self.key = key

    def get(self):
        return self.box[self.key]

    def set(self, v):
        self.box[self.key] = v


class Arr:
    """An array with a lower bound; out-of-range indexes are errors."""

    __slots__ = ("lo", "items")

    def __init__(self, lo, items):
        self.lo = lo
        self.items = items

    def __getitem__(self, i):
        j = i - self.lo
        if j < 0 or j >= len(self.items):
            raise StError(f"array index {i} outside {self.lo}..{self.lo + len(self.items) - 1}")
        return self.items[j]

    def __setitem__(self, i, v):
        j = i - self.lo
        if j < 0 or j >= len(self.items):
            raise StError(f"array index {i} outside {self.lo}..{self.lo + len(self.items) - 1}")
        self.items[j] = v

    def __deepcopy__(self, memo):
        return Arr(self.lo, copy.deepcopy(self.items, memo))


class Instance:
    """An FB instance: its variables, by upper-case name."""

    def __init__(self, pou, vars_):
        self.pou = pou
        self.vars = vars_

    def __getitem__(self, k):
        return self.vars[k]

    def __setitem__(self, k, v):
        self.vars[k] = v

    def __deepcopy__(self, memo):
        return Instance(self.pou, copy.deepcopy(self.vars, memo))


class _Return(Exception):
    pass


class _Exit(Exception):
    pass


def unescape(s: str) -> str:
    out, i = [], 0
    while i < len(s):
        c = s[i]
        if c == "$" and i + 1 < len(s):
            n = s[i + 1]
            table = {"$": "$", "'": "'", '"': '"', "L": "\n", "N": "\n", "P": "\f", "R": "\r", "T": "\t"}
            if n.upper() in table:
                out.append(table[n.upper()])
                i += 2
                continue
            out.append(chr(int(s[i + 1:i + 3], 16)))
            i += 3
            continue
        out.append(c)
        i += 1
    return "".join(out)


_PARSED: dict = {}
CACHE = os.environ.get("PLC_PARSE_CACHE")

# Top-level declarations end at these lines: each is parsed on its own
# (blark's Earley parser takes seconds per POU and grows with the length).
_SPLIT = re.compile(r"(?m)^(END_FUNCTION_BLOCK|END_FUNCTION|END_TYPE|END_PROGRAM)[ \t]*(\(\*.*\*\))?[ \t]*\n")


def chunks(text: str):
    """(first line, text) of each top-level declaration of a source."""
    out, start = [], 0
    for m in _SPLIT.finditer(text):
        out.append((text.count("\n", 0, start) + 1, text[start:m.end()]))
        start = m.end()
    if text[start:].strip():
        out.append((text.count("\n", 0, start) + 1, text[start:]))
    return out


_CHUNKS: dict = {}   # this process's parses: key -> items, or the StError's text


def chunk_key(text: str) -> str:
    """The cache key of a declaration: its text and the parser's versions
    (the same text parses to the same tree in every run)."""
    import hashlib
    import blark
    import lark
    return hashlib.sha256(f"{blark.__version__}\0{lark.__version__}\0{text}".encode()).hexdigest()


def _parse_uncached(path, line: int, text: str, key: str):
    """Parses one declaration: its items, or the error's text."""
    import pickle
    res = blark_parse.parse_source_code(text, fn=str(path))
    if res.exception is not None:
        return f"{path} (declaration from line {line}): {res.exception}"
    items = res.transform().items
    if CACHE:
        os.makedirs(CACHE, exist_ok=True)
        tmp = os.path.join(CACHE, f"{key}.{os.getpid()}.tmp")
        with open(tmp, "wb") as fh:
            pickle.dump(items, fh)
        os.replace(tmp, os.path.join(CACHE, key + ".pickle"))
    return items


def _cached(key: str):
    """A parse this process or the disk cache already has, else None."""
    import pickle
    if key in _CHUNKS:
        return _CHUNKS[key]
    if CACHE:
        f = os.path.join(CACHE, key + ".pickle")
        if os.path.exists(f):
            with open(f, "rb") as fh:
                _CHUNKS[key] = pickle.load(fh)
            return _CHUNKS[key]
    return None


def parse_chunk(path, line: int, text: str):
    """blark's transformed items of one declaration (kept for this process,
    and on disk by the key when PLC_PARSE_CACHE names a directory)."""
    key = chunk_key(text)
    got = _cached(key)
    if got is None:
        got = _CHUNKS[key] = _parse_uncached(path, line, text, key)
    if isinstance(got, str):
        raise StError(got)
    return got


def _parse_job(job):
    path, line, text, key = job
    return key, _parse_uncached(path, line, text, key)


def preparse(paths, jobs: int = 2) -> int:
    """Parses every declaration of these files that is not cached yet, in
    `jobs` processes, the longest first (blark's Earley parser takes about
    a second per kilobyte; a cold run of the tests is mostly this). Errors
    are kept and raised where the declaration is used. Returns how many
    declarations were parsed."""
    todo, seen = [], set()
    for path in paths:
        for line, text in chunks(open(path, encoding="utf-8").read()):
            key = chunk_key(text)
            if key not in seen and _cached(key) is None:
                seen.add(key)
                todo.append((str(path), line, text, key))
    if not todo:
        return 0
    todo.sort(key=lambda job: -len(job[2]))
    blark_parse.get_parser()  # built once, inherited by the workers
    if jobs <= 1 or len(todo) == 1:
        results = map(_parse_job, todo)
        for key, got in results:
            _CHUNKS[key] = got
        return len(todo)
    import multiprocessing
    with multiprocessing.get_context("fork").Pool(min(jobs, len(todo))) as pool:
        for key, got in pool.imap_unordered(_parse_job, todo, chunksize=1):
            _CHUNKS[key] = got
    return len(todo)


def parsed_chunks(path):
    """(first line, text, blark's transformed items) of each top-level
    declaration of a file; positions in the items' meta are offsets in that
    declaration's text (the exporters cut literal source text by them)."""
    key = (str(path), os.stat(path).st_mtime_ns)
    if key not in _PARSED:
        text = open(path, encoding="utf-8").read()
        _PARSED[key] = [(line, chunk, parse_chunk(path, line, chunk)) for line, chunk in chunks(text)]
    return _PARSED[key]


def parsed_items(path):
    """blark's transformed items of a file, declaration by declaration."""
    return [item for _, _, items in parsed_chunks(path) for item in items]


class Native:
    """A function block written in Python: a platform's own block that no
    ST source declares (e.g. Siemens MB_CLIENT, emulated by a test). `meta`
    maps its variables' upper-case names to (kind, Type), kind one of "in",
    "out", "inout" (VARIANT and other by-reference parameters), "var";
    `call(program, inst)` runs it with the inputs stored in inst.vars and
    the in-outs as Refs."""

    meta: dict = {}

    def call(self, program: "Program", inst: "Instance") -> None:
        raise NotImplementedError


class Program:
    """Parsed sources, ready to instantiate and run."""

    def __init__(self, paths, clock=None, natives=None, located=False):
        self.types: dict[str, object] = {}
        # located=True: a PROGRAM's located variables (a VAR block of their
        # own, AT %IW100 ...) are plain variables of its instance, their
        # addresses in self.locations[program][variable] (for a test that
        # plays the runtime's part, e.g. OpenPLC's slave devices).
        self.located = located
        self.locations: dict[str, dict[str, str]] = {}
        self.pous: dict[str, object] = {}
        self.enum_values: dict[str, tuple[str, int]] = {}
        self.clock = clock or (lambda: 0.0)
        self.natives: dict[str, Native] = {k.upper(): v for k, v in (natives or {}).items()}
        self._metas = {}
        for p in paths:
            for item in parsed_items(p):
                self._add(item)

    # ------------------------------------------------------------ declarations
    def _add(self, item):
        if isinstance(item, tf.DataTypeDeclaration):
            d = item.declaration
            self.types[str(d.name).upper()] = d
            if isinstance(d, tf.EnumeratedTypeDeclaration):
                for i, v in enumerate(d.init.spec.values):
                    self.enum_values[str(v.name).upper()] = (str(d.name).upper(), i)
        elif isinstance(item, (tf.Function, tf.FunctionBlock, tf.Program)):
            self.pous[str(item.name).upper()] = item
        else:
            raise StError(f"top-level {type(item).__name__} not supported")

    def resolve_type(self, spec) -> Type:
        if isinstance(spec, str):
            name = spec.upper()
            if name in INT_TYPES:
                return Type("int", name)
            if name in REAL_TYPES:
                return Type("real", name)
            if name == "BOOL":
                return Type("bool", name)
            if name == "TIME":
                return Type("time", name)
            if name == "STRING":
                return Type("string", name, length=254)
            m = re.fullmatch(r"STRING\s*[\(\[]\s*(\d+)\s*[\)\]]", name)
            if m:
                return Type("string", "STRING", length=int(m.group(1)))
            if name in ("R_TRIG", "F_TRIG", "TON") or name in self.natives:
                return Type("fb", name)
            if name in self.pous:
                return Type("fb", name)
            if name in self.types:
                return self._declared(self.types[name])
            raise StError(f"unknown type {spec}")
        if isinstance(spec, (tf.SimpleSpecification, tf.IndirectSimpleSpecification)):
            if getattr(spec, "indirection", None):
                raise StError("pointers/references are outside the subset")
            return self.resolve_type(str(spec.type))
        if isinstance(spec, tf.DataType):
            if spec.indirection:
                raise StError("pointers/references are outside the subset")
            return self.resolve_type(str(spec.type_name))
        if isinstance(spec, tf.StringTypeSpecification):
            n = 254
            if spec.length is not None:
                n = int(str(spec.length.length))
            return Type("string", "STRING", length=n)
        if isinstance(spec, tf.ArraySpecification):
            if len(spec.subranges) != 1:
                raise StError("only one-dimensional arrays are in the subset")
            sr = spec.subranges[0]
            lo, hi = self.const(sr.start), self.const(sr.stop)
            return Type("array", "ARRAY", lo=lo, hi=hi, elem=self.resolve_type(spec.type))
        raise StError(f"type form {type(spec).__name__} not supported")

    def _declared(self, d) -> Type:
        if isinstance(d, tf.ArrayTypeDeclaration):
            return self.resolve_type(d.init.spec)
        if isinstance(d, tf.StructureTypeDeclaration):
            t = Type("struct", str(d.name).upper())
            for el in d.declarations:
                ty = self.type_of_init(el.init)
                for v in el.variables:
                    t.fields[str(v.name if hasattr(v, 'name') else v).upper()] = (ty, getattr(el.init, "value", None))
            return t
        if isinstance(d, tf.EnumeratedTypeDeclaration):
            return Type("enum", str(d.name).upper(), values=[str(v.name).upper() for v in d.init.spec.values])
        if isinstance(d, tf.SimpleTypeDeclaration):
            # An alias of an elementary type (TYPE HW_ANY : UINT; END_TYPE).
            if d.init.value is not None:
                raise StError(f"{d.name}: an alias with an initial value is outside the subset")
            return self.resolve_type(d.init.spec)
        raise StError(f"type declaration {type(d).__name__} not supported")

    def type_of_init(self, init) -> Type:
        if isinstance(init, (tf.TypeInitialization, tf.ArrayTypeInitialization, tf.EnumeratedTypeInitialization)):
            if getattr(init, "indirection", None):
                raise StError("pointers/references are outside the subset")
            return self.resolve_type(init.spec) if not isinstance(init.spec, tf.EnumeratedSpecification) else \
                Type("enum", "", values=[str(v.name).upper() for v in init.spec.values])
        if isinstance(init, tf.StringTypeSpecification):
            return self.resolve_type(init)
        if isinstance(init, tf.StringTypeInitialization) if hasattr(tf, "StringTypeInitialization") else False:
            return self.resolve_type(init.spec)
        if hasattr(init, "spec"):
            return self.resolve_type(init.spec)
        raise StError(f"declaration form {type(init).__name__} not supported")

    def const(self, expr) -> int:
        v = self.eval(expr, None)
        if not isinstance(v, int):
            raise StError(f"constant expected: {expr}")
        return v

    def default(self, t: Type):
        if t.kind == "int":
            return 0
        if t.kind == "real":
            return 0.0
        if t.kind == "bool":
            return False
        if t.kind == "time":
            return 0.0
        if t.kind == "string":
            return ""
        if t.kind == "enum":
            return t.values[0] if t.values else ""
        if t.kind == "array":
            return Arr(t.lo, [self.default(t.elem) for _ in range(t.hi - t.lo + 1)])
        if t.kind == "struct":
            d = {}
            for k, (ft, init) in t.fields.items():
                d[k] = self.coerce(self.eval(init, None), ft) if init is not None else self.default(ft)
            return d
        if t.kind == "fb":
            return self.instantiate(t.name)
        raise StError(f"no default for {t.kind}")

    def coerce(self, v, t: Type):
        if t.kind == "int":
            if isinstance(v, bool):
                v = int(v)
            if isinstance(v, float):
                raise StError(f"REAL stored in {t.name} without a conversion")
            return wrap(v, t.name)
        if t.kind == "real":
            return f32(float(v)) if t.name == "REAL" else float(v)
        if t.kind == "bool":
            return bool(v)
        if t.kind == "string":
            return str(v)[: t.length]
        if t.kind in ("array", "struct"):
            return copy.deepcopy(v)
        return v

    # ------------------------------------------------------------- instances
    def var_blocks(self, pou):
        for block in pou.declarations:
            kind = {
                tf.InputDeclarations: "in", tf.OutputDeclarations: "out",
                tf.InputOutputDeclarations: "inout", tf.VariableDeclarations: "var",
                tf.FunctionVariableDeclarations: "var",
            }.get(type(block))
            if self.located and isinstance(block, tf.LocatedVariableDeclarations) \
                    and isinstance(pou, tf.Program):
                where = self.locations.setdefault(str(pou.name).upper(), {})
                for item in block.items:
                    vname = str(item.name).upper()
                    where[vname] = str(item.location).replace("AT ", "").strip()
                    yield "var", vname, self.type_of_init(item.init), getattr(item.init, "value", None)
                continue
            if kind is None:
                raise StError(f"{pou.name}: {type(block).__name__} is outside the subset")
            for item in block.items:
                if not isinstance(item, tf.VariableOneInitDeclaration):
                    raise StError(f"{pou.name}: declaration {type(item).__name__} is outside the subset")
                t = self.type_of_init(item.init)
                for dv in item.variables:
                    if getattr(dv, "location", None):
                        raise StError(f"{pou.name}: located variable {dv} (adapters only)")
                    yield kind, str(dv.variable.name).upper(), t, getattr(item.init, "value", None)

    def fb_meta(self, name: str) -> dict:
        """An FB type's variables: name -> (kind, Type)."""
        if name in self.natives:
            return self.natives[name].meta
        if name not in self._metas:
            self._metas[name] = {} if name not in self.pous else {
                vname: (kind, t) for kind, vname, t, _ in self.var_blocks(self.pous[name])}
        return self._metas[name]

    def instantiate(self, name: str) -> Instance:
        name = name.upper()
        if name in ("R_TRIG", "F_TRIG"):
            return Instance(name, {"CLK": False, "Q": False, "M": False})
        if name == "TON":
            return Instance(name, {"IN": False, "PT": 0.0, "Q": False, "ET": 0.0, "START": None})
        if name in self.natives:
            meta = self.natives[name].meta
            inst = Instance(name, {k: None if kind == "inout" else self.default(t) for k, (kind, t) in meta.items()})
            inst.meta = meta
            return inst
        pou = self.pous[name]
        vars_ = {}
        meta = {}
        for kind, vname, t, init in self.var_blocks(pou):
            meta[vname] = (kind, t)
            vars_[vname] = None if kind == "inout" else (
                self.coerce(self.eval(init, None), t) if init is not None else self.default(t))
        inst = Instance(name, vars_)
        inst.meta = meta
        return inst

    # -------------------------------------------------------------- running
    def call_fb(self, inst: Instance, args: dict):
        """Calls an FB instance: args maps upper-case input names to values,
        in-out names to Refs."""
        if inst.pou in ("R_TRIG", "F_TRIG", "TON"):
            for k, v in args.items():
                inst.vars[k] = v
            self._std_fb(inst)
            return
        for k, v in args.items():
            kind, t = inst.meta.get(k, (None, None))
            if kind == "in":
                inst.vars[k] = self.coerce(v, t)
            elif kind == "inout":
                inst.vars[k] = v
            else:
                raise StError(f"{inst.pou}: {k} is not an input or in-out")
        for k, (kind, _) in inst.meta.items():
            if kind == "inout" and inst.vars[k] is None:
                raise StError(f"{inst.pou}: in-out {k} not bound")
        if inst.pou in self.natives:
            self.natives[inst.pou].call(self, inst)
            return
        try:
            self.exec_list(self.pous[inst.pou].body, inst)
        except _Return:
            pass

    def _std_fb(self, inst):
        v = inst.vars
        if inst.pou == "R_TRIG":
            v["Q"] = bool(v["CLK"]) and not v["M"]
            v["M"] = bool(v["CLK"])
        elif inst.pou == "F_TRIG":
            v["Q"] = (not v["CLK"]) and (not v["M"])
            v["M"] = not v["CLK"]
        else:  # TON
            now = self.clock()
            if not v["IN"]:
                v["Q"], v["ET"], v["START"] = False, 0.0, None
            else:
                if v["START"] is None:
                    v["START"] = now
                v["ET"] = min(now - v["START"], v["PT"])
                v["Q"] = v["ET"] >= v["PT"]

    def call_function(self, name: str, params, frame):
        pou = self.pous[name]
        ret_t = self.resolve_type(pou.return_type) if pou.return_type is not None else None
        local = Instance(name, {})
        local.meta = {}
        for kind, vname, t, init in self.var_blocks(pou):
            local.meta[vname] = (kind, t)
            local.vars[vname] = None if kind == "inout" else (
                self.coerce(self.eval(init, None), t) if init is not None else self.default(t))
        local.vars[name] = self.default(ret_t) if ret_t else None
        local.meta[name] = ("var", ret_t)
        for p in params:
            if p.name is None:
                raise StError(f"call of {name}: formal (named) arguments only")
            k = str(p.name.name if hasattr(p.name, "name") else p.name).upper()
            kind, t = local.meta[k]
            if kind == "inout":
                local.vars[k] = self.ref(p.value, frame)
            else:
                local.vars[k] = self.coerce(self.eval(p.value, frame), t)
        try:
            self.exec_list(pou.body, local)
        except _Return:
            pass
        return local.vars[name]

    def invoke(self, name: str, **values):
        """Calls function `name` with Python values (in-out: a Ref)."""
        name = name.upper()
        pou = self.pous[name]
        ret_t = self.resolve_type(pou.return_type)
        local = Instance(name, {})
        local.meta = {}
        for kind, vname, t, init in self.var_blocks(pou):
            local.meta[vname] = (kind, t)
            local.vars[vname] = None if kind == "inout" else (
                self.coerce(self.eval(init, None), t) if init is not None else self.default(t))
        local.vars[name] = self.default(ret_t)
        local.meta[name] = ("var", ret_t)
        for k, v in values.items():
            kind, t = local.meta[k.upper()]
            local.vars[k.upper()] = v if kind == "inout" else self.coerce(v, t)
        try:
            self.exec_list(pou.body, local)
        except _Return:
            pass
        return local.vars[name]

    # ------------------------------------------------------------ variables
    def lookup(self, frame: Instance, name: str):
        """The storage place of a variable name in a frame (following in-out refs)."""
        if frame is None or name not in frame.vars:
            raise KeyError(name)
        v = frame.vars[name]
        if isinstance(v, Ref):
            return v
        return Ref(frame.vars, name)

    def ref(self, expr, frame) -> Ref:
        if isinstance(expr, tf.SimpleVariable):
            if expr.dereferenced:
                raise StError("dereferencing is outside the subset")
            return self.lookup(frame, str(expr.name).upper())
        if isinstance(expr, tf.MultiElementVariable):
            if expr.dereferenced:
                raise StError("dereferencing is outside the subset")
            r = self.lookup(frame, str(expr.name).upper())
            for el in expr.elements:
                box = r.get()
                if isinstance(el, tf.SubscriptList):
                    if len(el.subscripts) != 1 or el.dereferenced:
                        raise StError("one subscript only")
                    r = Ref(box, self.eval(el.subscripts[0], frame))
                elif isinstance(el, tf.FieldSelector):
                    if el.dereferenced:
                        raise StError("dereferencing is outside the subset")
                    key = str(el.field.name if hasattr(el.field, "name") else el.field).upper()
                    if isinstance(box, Instance):
                        r = Ref(box.vars, key)
                    else:
                        r = Ref(box, key)
                else:
                    raise StError(f"element {type(el).__name__}")
            return r
        raise StError(f"not a variable: {expr}")

    def type_at(self, expr, frame):
        """The declared elementary type of a variable expression, if known."""
        try:
            if isinstance(expr, tf.SimpleVariable):
                meta = getattr(frame, "meta", {})
                kind, t = meta.get(str(expr.name).upper(), (None, None))
                return t.name if t is not None else None
            if isinstance(expr, tf.BitString) and expr.type_name:
                return str(expr.type_name).upper()
            if isinstance(expr, tf.FunctionCall):
                n = str(expr.name).upper()
                if n in ("SHL", "SHR"):
                    return self.type_at(expr.parameters[0].value, frame)
                if "_TO_" in n:
                    return n.split("_TO_")[1]
                if n in self.pous and self.pous[n].return_type is not None:
                    return str(self.pous[n].return_type).upper()
            if isinstance(expr, tf.MultiElementVariable):
                # the image's words
                return None
        except Exception:  # noqa: BLE001 - only a hint
            return None
        return None

    # ----------------------------------------------------------- statements
    def exec_list(self, body, frame):
        stmts = body.statements if isinstance(body, tf.StatementList) else body
        for s in stmts or []:
            self.exec(s, frame)

    def exec(self, s, frame):
        if isinstance(s, tf.AssignmentStatement):
            v = self.eval(s.expression, frame)
            for var in s.variables:
                r = self.ref(var, frame)
                self.store(r, v, var, frame)
        elif isinstance(s, tf.IfStatement):
            if self.truth(s.if_expression, frame):
                self.exec_list(s.statements, frame)
                return
            for ei in s.else_ifs:
                if self.truth(ei.if_expression, frame):
                    self.exec_list(ei.statements, frame)
                    return
            if s.else_clause is not None:
                self.exec_list(s.else_clause.statements, frame)
        elif isinstance(s, tf.CaseStatement):
            v = self.eval(s.expression, frame)
            for c in s.cases:
                for m in c.matches:
                    if isinstance(m, tf.Subrange) if hasattr(tf, "Subrange") else False:
                        pass
                    if type(m).__name__ in ("PartialSubrange", "FullSubrange"):
                        if self.eval(m.start, frame) <= v <= self.eval(m.stop, frame):
                            self.exec_list(c.statements, frame)
                            return
                    elif self.eval(m, frame) == v:
                        self.exec_list(c.statements, frame)
                        return
            if s.else_clause is not None:
                self.exec_list(s.else_clause.statements, frame)
        elif isinstance(s, tf.ForStatement):
            r = self.ref(s.control, frame)
            start, stop = self.eval(s.from_, frame), self.eval(s.to, frame)
            step = self.eval(s.step, frame) if s.step is not None else 1
            r.set(start)
            try:
                while (r.get() <= stop) if step > 0 else (r.get() >= stop):
                    self.exec_list(s.statements, frame)
                    r.set(r.get() + step)
            except _Exit:
                pass
        elif isinstance(s, tf.WhileStatement):
            try:
                while self.truth(s.expression, frame):
                    self.exec_list(s.statements, frame)
            except _Exit:
                pass
        elif isinstance(s, tf.RepeatStatement):
            try:
                while True:
                    self.exec_list(s.statements, frame)
                    if self.truth(s.expression, frame):
                        break
            except _Exit:
                pass
        elif isinstance(s, tf.FunctionCallStatement):
            self.call(s, frame)
        elif isinstance(s, tf.ReturnStatement):
            raise _Return()
        elif isinstance(s, tf.ExitStatement):
            raise _Exit()
        else:
            raise StError(f"statement {type(s).__name__} is outside the subset")

    def store(self, r: Ref, v, var, frame):
        old = r.get()
        if isinstance(old, bool):
            r.set(bool(v))
        elif isinstance(old, int):
            t = self._int_type_of(var, frame)
            if isinstance(v, float):
                raise StError(f"REAL stored in an integer without a conversion: {var}")
            r.set(wrap(int(v), t) if t else int(v))
        elif isinstance(old, float):
            t = self._decl_type(var, frame)
            r.set(f32(float(v)) if t in (None, "REAL") else float(v))
        elif isinstance(old, str):
            t = self._decl(var, frame)
            r.set(str(v)[: t.length] if t is not None and t.kind == "string" else str(v))
        else:
            r.set(copy.deepcopy(v))

    def _decl(self, var, frame):
        """The declared Type of a variable expression (for wrapping)."""
        if isinstance(var, tf.SimpleVariable):
            k, t = getattr(frame, "meta", {}).get(str(var.name).upper(), (None, None))
            return t
        if isinstance(var, tf.MultiElementVariable):
            k, t = getattr(frame, "meta", {}).get(str(var.name).upper(), (None, None))
            if t is None:
                return None
            for el in var.elements:
                if t is None:
                    return None
                if isinstance(el, tf.SubscriptList):
                    t = t.elem
                elif isinstance(el, tf.FieldSelector):
                    key = str(el.field.name if hasattr(el.field, "name") else el.field).upper()
                    if t.kind == "struct":
                        t = t.fields[key][0]
                    elif t.kind == "fb":
                        t = self.fb_meta(t.name).get(key, (None, None))[1]
                    else:
                        return None
            return t
        return None

    def _decl_type(self, var, frame):
        t = self._decl(var, frame)
        return t.name if t is not None else None

    def _int_type_of(self, var, frame):
        t = self._decl(var, frame)
        if t is not None and t.kind == "int":
            return t.name
        return None

    # ---------------------------------------------------------- expressions
    def truth(self, e, frame) -> bool:
        v = self.eval(e, frame)
        if not isinstance(v, bool):
            raise StError(f"BOOL expected: {e}")
        return v

    def call(self, c, frame):
        name = str(c.name).upper()
        if c.dereferenced:
            raise StError("dereferencing is outside the subset")
        # An FB instance of the frame?
        if frame is not None and name in frame.vars:
            inst = self.lookup(frame, name).get()
            if not isinstance(inst, Instance):
                raise StError(f"{name} is not a function block instance")
            args = {}
            for p in c.parameters:
                if p.name is None:
                    raise StError(f"call of {name}: formal (named) arguments only")
                if type(p).__name__ == "OutputParameterAssignment":
                    raise StError("=> output assignment is outside the subset")
                k = str(p.name.name if hasattr(p.name, "name") else p.name).upper()
                meta = getattr(inst, "meta", {})
                if meta.get(k, (None,))[0] == "inout":
                    args[k] = self.ref(p.value, frame)
                else:
                    args[k] = self.eval(p.value, frame)
            self.call_fb(inst, args)
            return None
        if name in self.pous:
            if not isinstance(self.pous[name], tf.Function):
                raise StError(f"{name} is a function block type, called without an instance")
            return self.call_function(name, c.parameters, frame)
        return self.std_function(name, c.parameters, frame)

    def std_function(self, name, params, frame):
        named = {}
        positional = []
        for p in params:
            if p.name is None:
                positional.append(self.eval(p.value, frame))
            else:
                named[str(p.name.name if hasattr(p.name, "name") else p.name).upper()] = (
                    self.eval(p.value, frame), p.value)
        if "_TO_" in name:
            src, dst = name.split("_TO_")
            (v,) = positional or [named[next(iter(named))][0]]
            if dst in INT_TYPES:
                if isinstance(v, float):
                    v = round_away(v)
                return wrap(int(v), dst)
            if dst in REAL_TYPES:
                return f32(float(v)) if dst == "REAL" else float(v)
            if dst == "BOOL":
                return v != 0
            raise StError(f"conversion {name}")
        if name in ("SHL", "SHR"):
            v, vexpr = named["IN"]
            n = named["N"][0]
            t = self.type_at(vexpr, frame) or "WORD"
            bits = INT_TYPES[t][0]
            r = (v << n) if name == "SHL" else (v >> n)
            return r & ((1 << bits) - 1)
        if name == "MID":
            s, l, p = named["IN"][0], named["L"][0], named["P"][0]
            return s[p - 1: p - 1 + l]
        if name == "CONCAT":
            return "".join(named[k][0] for k in sorted(named)) if named else "".join(positional)
        if name == "LEN":
            return len((positional or [named["IN"][0]])[0])
        if name == "ABS":
            return abs((positional or [named["IN"][0]])[0])
        if name in ("MIN", "MAX"):
            vals = positional or [v for v, _ in named.values()]
            return min(vals) if name == "MIN" else max(vals)
        raise StError(f"function {name} is not known here")

    def eval(self, e, frame):
        if isinstance(e, tf.HexInteger):
            return int(str(e.value).replace("_", ""), 16)
        if type(e).__name__ in ("OctalInteger", "BinaryInteger"):
            return int(str(e.value).replace("_", ""), 8 if type(e).__name__ == "OctalInteger" else 2)
        if isinstance(e, tf.Integer):
            return int(str(e.value).replace("_", ""))
        if isinstance(e, tf.BitString):
            v = str(e.value)
            if "#" in v:
                base, digits = v.split("#", 1)
                return int(digits.replace("_", ""), int(base))
            return int(v.replace("_", ""))
        if isinstance(e, tf.Real):
            return float(str(e.value))
        if isinstance(e, tf.Boolean):
            return str(e.value).upper() in ("TRUE", "1")
        if isinstance(e, tf.Duration):
            ms = 0.0
            for f, k in (("days", 86400.0), ("hours", 3600.0), ("minutes", 60.0), ("seconds", 1.0),
                         ("milliseconds", 0.001)):
                v = getattr(e, f)
                if v is not None:
                    ms += float(str(v)) * k
            return -ms if e.negative else ms
        if isinstance(e, tf.String):
            s = str(e.value)
            return unescape(s[1:-1])
        if isinstance(e, tf.ParenthesizedExpression):
            return self.eval(e.expr, frame)
        if isinstance(e, tf.UnaryOperation):
            op = str(e.op).upper()
            v = self.eval(e.expr, frame)
            if op == "NOT":
                if isinstance(v, bool):
                    return not v
                t = self.type_at(e.expr, frame) or "WORD"
                return ~v & ((1 << INT_TYPES[t][0]) - 1)
            if op == "-":
                return -v
            if op == "+":
                return v
            raise StError(f"unary {op}")
        if isinstance(e, tf.BinaryOperation):
            op = str(e.op).upper()
            a = self.eval(e.left, frame)
            if op in ("AND", "AND_THEN") and isinstance(a, bool) and not a:
                b = self.eval(e.right, frame)
                return False
            b = self.eval(e.right, frame)
            if op == "+":
                return a + b
            if op == "-":
                return a - b
            if op == "*":
                return a * b
            if op == "/":
                if isinstance(a, float) or isinstance(b, float):
                    return a / b
                if b == 0:
                    raise StError("integer division by zero")
                q = abs(a) // abs(b)
                return q if (a >= 0) == (b >= 0) else -q
            if op == "MOD":
                if b == 0:
                    return 0
                return a - b * (abs(a) // abs(b) * (1 if (a >= 0) == (b >= 0) else -1))
            if op in ("=", "<>", "<", ">", "<=", ">="):
                return {"=": a == b, "<>": a != b, "<": a < b, ">": a > b, "<=": a <= b, ">=": a >= b}[op]
            if op in ("AND", "&"):
                return (a and b) if isinstance(a, bool) else (a & b)
            if op == "OR":
                return (a or b) if isinstance(a, bool) else (a | b)
            if op == "XOR":
                return (a != b) if isinstance(a, bool) else (a ^ b)
            raise StError(f"operator {op}")
        if isinstance(e, tf.FunctionCall):
            return self.call(e, frame)
        if isinstance(e, tf.SimpleVariable):
            name = str(e.name).upper()
            if frame is not None and name in frame.vars:
                return self.lookup(frame, name).get()
            if name in self.enum_values:
                return name
            raise StError(f"unknown variable {e.name}")
        if isinstance(e, tf.MultiElementVariable):
            return self.ref(e, frame).get()
        if isinstance(e, tf.EnumeratedValue):
            return str(e.name).upper()
        raise StError(f"expression {type(e).__name__} is outside the subset")


def enum_index(value: str, t: Type) -> int:
    return t.values.index(value)
