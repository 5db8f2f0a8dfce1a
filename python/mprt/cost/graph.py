"""Operation graphs: the vocabulary of every kernel (operation classes, Graph, the builder).

A kernel is the straight-line path the common case takes through our C code
(``c/src/render.c``, ``ray.c``, ``prim_*.c``), written as operations of seven
classes with their data dependences:

    int     integer ALU: address arithmetic, integer compare, select, convert
    fadd    floating-point add/subtract, compare, abs, negate, min/max, int<->float
    fmul    floating-point multiply
    fdiv    floating-point divide and square root
    load    a read of local memory (voxel table, primitive data, materials)
    store   a write of local memory or of a FIFO port
    branch  a conditional or computed branch

Operands already in registers (the ray, once its packet is read) cost
nothing.  Branches carry no control dependence: a VLIW compiler moves
operations across them (trace scheduling), and on a sequential processor the
order does not matter.  Counts follow the code path stated in each graph's
comment, so a kernel's cost on a one-unit processor is the sum of its
operations' latencies.
"""
from __future__ import annotations

from dataclasses import dataclass

OP_CLASSES = ("int", "fadd", "fmul", "fdiv", "load", "store", "branch")
_CLASS_INDEX = {c: i for i, c in enumerate(OP_CLASSES)}

R = None  # an operand held in a register: no producing operation
REG3 = (R, R, R)


@dataclass(frozen=True)
class Graph:
    """A kernel: operation classes (as indices into OP_CLASSES) and, per
    operation, the operations whose results it reads.  Operations appear in
    program order, so every dependence points backwards."""

    name: str
    doc: str
    ops: tuple
    deps: tuple

    def counts(self) -> dict:
        """Operations per class."""
        c = dict.fromkeys(OP_CLASSES, 0)
        for k in self.ops:
            c[OP_CLASSES[k]] += 1
        return c

    def __len__(self):
        return len(self.ops)

    @classmethod
    def from_list(cls, name: str, ops, doc: str = "") -> "Graph":
        """A graph from [(class name, (dependence indices...)), ...] in program order."""
        classes, deps = [], []
        for i, (c, d) in enumerate(ops):
            if c not in _CLASS_INDEX:
                raise ValueError(f"graph {name!r}, operation {i}: unknown class {c!r} (known: {', '.join(OP_CLASSES)})")
            d = tuple(sorted(set(d)))
            if any(not 0 <= j < i for j in d):
                raise ValueError(f"graph {name!r}, operation {i}: dependences must name earlier operations")
            classes.append(_CLASS_INDEX[c])
            deps.append(d)
        return cls(name, doc, tuple(classes), tuple(deps))


class _Builder:
    """Records operations; each method returns the new operation's id."""

    def __init__(self):
        self.ops, self.deps = [], []

    def op(self, cls, *deps):
        self.ops.append(_CLASS_INDEX[cls])
        self.deps.append(tuple(sorted({d for d in deps if d is not None})))
        return len(self.ops) - 1

    def int(self, *d):
        return self.op("int", *d)

    def fadd(self, *d):
        return self.op("fadd", *d)

    def fmul(self, *d):
        return self.op("fmul", *d)

    def fdiv(self, *d):
        return self.op("fdiv", *d)

    def load(self, *d):
        return self.op("load", *d)

    def store(self, *d):
        return self.op("store", *d)

    def branch(self, *d):
        return self.op("branch", *d)

    # -- vector helpers (3-vectors are tuples of operation ids or R) --------
    def load3(self, *d):
        return tuple(self.load(*d) for _ in range(3))

    def sub3(self, a, b):
        return tuple(self.fadd(a[i], b[i]) for i in range(3))

    def scale3(self, a, s):
        return tuple(self.fmul(a[i], s) for i in range(3))

    def madd3(self, a, b, s):
        """a + b * s"""
        return tuple(self.fadd(a[i], self.fmul(b[i], s)) for i in range(3))

    def dot(self, a, b):
        m = [self.fmul(a[i], b[i]) for i in range(3)]
        return self.fadd(self.fadd(m[0], m[1]), m[2])

    def norm3(self, a):
        """vnorm: length by sqrt, a test l > 0, one reciprocal, three products."""
        ln = self.fdiv(self.dot(a, a))
        self.branch(self.fadd(ln))
        return self.scale3(a, self.fdiv(ln))

    def test(self, *d):
        """compare and branch on it"""
        c = self.fadd(*d)
        self.branch(c)
        return c

    def itest(self, *d):
        c = self.int(*d)
        self.branch(c)
        return c

    def graph(self, name, doc):
        return Graph(name, doc, tuple(self.ops), tuple(self.deps))


