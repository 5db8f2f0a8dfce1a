"""The kernels of the three processors, each described once as an operation graph.

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


# ---- OS ----------------------------------------------------------------------

def _os_setup():
    """OS ray set-up, once per ray: mprt__ray_prepare (reciprocal direction;
    the dominant axis and the shear rows of the watertight polygon test) and
    dda_begin (clip to the grid box by slabs, first voxel, per axis the step,
    first boundary crossing and crossing spacing, the voxel's exit t)."""
    b = _Builder()
    # reciprocal direction, with a zero test per axis
    inv = []
    for _ in range(3):
        b.test(R)
        inv.append(b.fdiv(R))
    # |d|, dominant axis kz, kx and ky following it, handedness swap
    ad = [b.fadd(R) for _ in range(3)]
    kz = b.int(b.test(ad[0], ad[1]), b.test(ad[0], ad[2]), b.test(ad[1], ad[2]))
    kx = b.int(b.itest(kz))
    ky = b.int(b.itest(kx))
    a_kz = b.load(kz)
    sw = b.test(a_kz)
    kx, ky = b.int(kx, ky, sw), b.int(kx, ky, sw)
    a_kx, a_ky = b.load(kx), b.load(ky)
    # shear constants and the rows mx, my (stored into zeroed arrays, read back)
    b.test(a_kz)
    sx = b.fadd(b.fdiv(a_kx, a_kz))
    sy = b.fadd(b.fdiv(a_ky, a_kz))
    b.fdiv(a_kz)
    for idx, val in ((kx, R), (kz, sx), (ky, R), (kz, sy)):
        b.store(b.int(idx), val)
    for _ in range(6):
        b.load(kz)
    # clip to the box grown by pad
    pad = b.load()
    t0, t1 = R, R
    for a in range(3):
        lo, hi = b.fadd(b.load(), pad), b.fadd(b.load(), pad)
        b.test(R)
        ta = b.fmul(b.fadd(lo, R), inv[a])
        tb = b.fmul(b.fadd(hi, R), inv[a])
        sw = b.test(ta, tb)
        t0 = b.fadd(t0, ta, tb, sw)
        t1 = b.fadd(t1, ta, tb, sw)
    b.test(t0, t1)
    # first voxel and per-axis walk state
    voxel = R
    tnext = []
    for a in range(3):
        x = b.fadd(R, b.fmul(t0, R))
        f = b.fmul(b.fadd(x, b.load()), b.load())
        c = b.fadd(b.test(f), b.test(f))            # clamp into 0..n-1, convert
        stride = b.int(b.load())
        voxel = b.int(voxel, b.int(c, stride))
        b.test(R)                                    # d[a] == 0
        step = b.int(b.fadd(R))
        i = b.fadd(b.int(c, step))                   # boundary index to float
        bound = b.fadd(b.load(), b.fmul(i, b.load()))
        tnext.append(b.fmul(b.fadd(bound, R), inv[a]))
        b.fmul(b.load(), b.fadd(inv[a]))             # tdelta = cell |inv|
        b.int(step, stride)                          # signed stride
    # t_exit = min(tnext), clamped to [t0, t1]
    m = b.fadd(b.fadd(tnext[0], tnext[1]), tnext[2])
    b.fadd(b.fadd(m, t1), t0)
    return b.graph("os_setup", _os_setup.__doc__)


def _os_step():
    """OS voxel step, once per voxel entered: dda_step (end-of-ray test, the
    axis whose boundary comes first, cell and voxel advance with the bounds
    test, next crossing, the new stretch's exit t) and the walk loop's read
    of the voxel's flag."""
    b = _Builder()
    b.test(R, R)                                    # t_exit >= t_end
    b.test(R, R)                                    # tnext[0] <= tnext[1]
    b.test(R, R)                                    # tnext[0] <= tnext[2]
    cell = b.int(R)
    b.itest(cell)                                   # still inside the grid
    voxel = b.int(R)
    tn = b.fadd(R, R)                               # tnext += tdelta
    t = b.fadd(b.fadd(tn, R), R)                    # min3
    t = b.fadd(b.test(t, R), t)                     # t > t_end
    b.fadd(t, R)                                    # t < t_enter
    b.int(R)                                        # voxels++
    b.test(b.load(b.int(voxel)))                    # flag[voxel]
    return b.graph("os_step", _os_step.__doc__)


def _os_visit():
    """OS visit dispatch, once per OS visit: what the walk found decides the
    destination (IC with the voxel id, SC for a shadow ray that left, or the
    ray dies), and the outgoing packet's destination is set."""
    b = _Builder()
    k = b.itest(R)                                  # flagged voxel or left?
    b.itest(k)                                      # shadow ray?
    b.int(k)                                        # destination
    return b.graph("os_visit", _os_visit.__doc__)


# ---- IC ----------------------------------------------------------------------

def _ic_visit():
    """IC visit overhead, once per IC visit: read the voxel's list bounds
    (start[v], start[v+1]), choose the search limit (shadow: tmax, else the
    nearest candidate so far), and after the loop decide hit / return by
    whether the candidate lies within the voxel's stretch."""
    b = _Builder()
    a = b.int(R)
    b.load(a)
    b.load(a)
    b.itest(R)                                      # any_hit?
    p = b.itest(R)                                  # best.prim >= 0
    b.branch(b.fadd(R, R), p)                       # best.t <= t_exit
    return b.graph("ic_visit", _ic_visit.__doc__)


def _prim_loop(b):
    """The loop around one test: next list entry, the primitive's table entry
    (kind, index), the address of its shape data, the switch on kind.
    Returns the address."""
    k = b.int(R)
    b.itest(k)                                      # k < k1
    pid = b.load(b.int(k))                          # ids[k]
    ent = b.int(pid)
    kind, idx = b.load(ent), b.load(ent)
    b.branch(b.int(kind))                           # switch
    return b.int(idx)                               # &shape[index]


def _after_test(b, hit):
    b.branch(hit)                                   # if (!test) continue


def _ic_sphere():
    """IC sphere test (mprt__sphere_hit), the path of a miss: the quadratic's
    coefficients about the centre, the moving-away early out, the
    cancellation-free discriminant a (r^2 - |f|^2) and its sign test;
    plus the list loop around it."""
    b = _Builder()
    adr = _prim_loop(b)
    c = b.load3(adr)
    r = b.load(adr)
    oc = b.sub3(REG3, c)
    a = b.dot(REG3, REG3)
    bb = b.dot(oc, REG3)
    r2 = b.fmul(r, r)
    cc = b.fadd(b.dot(oc, oc), r2)
    b.test(cc)
    b.test(bb)
    s = b.fadd(b.fdiv(bb, a))                        # -b / a
    f = b.madd3(oc, REG3, s)
    disc = b.fmul(a, b.fadd(r2, b.dot(f, f)))
    _after_test(b, b.test(disc))
    return b.graph("ic_sphere", _ic_sphere.__doc__)


def _ic_polygon():
    """IC polygon test, the per-polygon part (mprt__polygon_hit): the plane
    hit (d.n, distance, range test), the first vertex moved into the ray's
    shear space, and the winding-number test; plus the list loop around it."""
    b = _Builder()
    adr = _prim_loop(b)
    first, n = b.load(adr), b.load(adr)
    nrm = b.load3(adr)
    pd = b.load(adr)
    dn = b.dot(nrm, REG3)
    b.test(dn)
    tt = b.fdiv(b.fadd(pd, b.dot(nrm, REG3)), dn)
    b.test(tt, R)
    b.test(tt, R)
    v = b.load3(b.int(first, n))
    q = b.sub3(v, REG3)
    b.dot(q, REG3)
    b.dot(q, REG3)
    _after_test(b, b.itest(R))                      # wn == 0
    return b.graph("ic_polygon", _ic_polygon.__doc__)


def _ic_vertex():
    """IC polygon test, per vertex: the vertex into shear space (two dot
    products with the shear rows), the half-open crossing tests, the edge
    function of the crossing edge and the winding update."""
    b = _Builder()
    v = b.load3(b.int(R))
    q = b.sub3(v, REG3)
    bx, by = b.dot(q, REG3), b.dot(q, REG3)
    b.test(R)                                       # ay <= 0
    b.test(by)                                      # by > 0 / by <= 0
    e = b.fadd(b.fmul(R, by), b.fmul(R, bx))         # ax by - ay bx
    b.int(b.test(e))                                # winding +-1
    b.int(R)                                        # i++, loop
    b.branch(R)
    return b.graph("ic_vertex", _ic_vertex.__doc__)


def _cone_local(b, adr):
    """cone_local: shift the origin to the ray point nearest the frustum's
    middle, the bounding-sphere reject, the origin and direction in the
    cone's frame (u, v, w)."""
    base = b.load3(adr)
    w = b.load3(adr)
    ln, rb, ra = b.load(adr), b.load(adr), b.load(adr)
    half = b.fmul(ln)
    rmax = b.fadd(b.test(rb, ra), rb, ra)
    m = b.madd3(base, w, half)
    om = b.sub3(m, REG3)
    dd = b.dot(REG3, REG3)
    b.test(dd)
    s = b.fdiv(b.dot(om, REG3), dd)
    e = b.sub3(b.scale3(REG3, s), om)
    r2 = b.fadd(b.fmul(half, half), b.fmul(rmax, rmax))
    b.test(b.dot(e, e), b.fmul(r2))
    p = b.madd3(e, w, half)
    u, v = b.load3(adr), b.load3(adr)
    o = (b.dot(p, u), b.dot(p, v), b.dot(p, w))
    d = (b.dot(REG3, u), b.dot(REG3, v), b.dot(REG3, w))
    return s, o, d, rb, ln


def _quadratic_roots(b, a, bb, cc, disc):
    """Stable roots q = -(b + sign(b) sqrt(disc)), s0 = q/a, s1 = c/q."""
    b.test(disc)
    b.test(bb)
    q = b.fadd(b.fadd(bb, b.fdiv(disc)))
    b.test(q)
    return b.fdiv(q, a), b.fdiv(cc, q)


def _cone_pick(b, tc, oz, dz, s0, s1, ln):
    """cone_pick: order the roots, the nearer one's t in range and height
    between the rims (the path that accepts the first root)."""
    sw = b.test(s0, s1)
    s0 = b.fadd(s0, s1, sw)
    tt = b.fadd(tc, s0)
    b.test(tt, R)
    b.test(tt, R)
    z = b.fadd(oz, b.fmul(s0, dz))
    b.test(z)
    return b.test(z, ln)


def _ic_cylinder():
    """IC cylinder test (mprt__cylinder_hit), the path through both roots:
    cone_local, x^2 + y^2 = r^2 as a quadratic with the discriminant written
    a (r^2 - |f|^2), stable roots and cone_pick; plus the list loop."""
    b = _Builder()
    adr = _prim_loop(b)
    tc, o, d, rb, ln = _cone_local(b, adr)
    a = b.fadd(b.fmul(d[0], d[0]), b.fmul(d[1], d[1]))
    b.test(a)
    bb = b.fadd(b.fmul(o[0], d[0]), b.fmul(o[1], d[1]))
    r2 = b.fmul(rb, rb)
    cc = b.fadd(b.fadd(b.fmul(o[0], o[0]), b.fmul(o[1], o[1])), r2)
    k = b.fdiv(bb, a)
    fx = b.fadd(o[0], b.fmul(k, d[0]))
    fy = b.fadd(o[1], b.fmul(k, d[1]))
    disc = b.fmul(a, b.fadd(r2, b.fadd(b.fmul(fx, fx), b.fmul(fy, fy))))
    s0, s1 = _quadratic_roots(b, a, bb, cc, disc)
    _after_test(b, _cone_pick(b, tc, o[2], d[2], s0, s1, ln))
    return b.graph("ic_cylinder", _ic_cylinder.__doc__)


def _ic_cone():
    """IC cone test (mprt__cone_hit), the path through both roots: cone_local,
    x^2 + y^2 = (rb + k z)^2 as a quadratic about the radius at the origin's
    height, stable roots and cone_pick; plus the list loop."""
    b = _Builder()
    adr = _prim_loop(b)
    tc, o, d, rb, ln = _cone_local(b, adr)
    k = b.load(adr)
    r0 = b.fadd(rb, b.fmul(k, o[2]))
    kd = b.fmul(k, d[2])
    a = b.fadd(b.fadd(b.fmul(d[0], d[0]), b.fmul(d[1], d[1])), b.fmul(kd, kd))
    bb = b.fadd(b.fadd(b.fmul(o[0], d[0]), b.fmul(o[1], d[1])), b.fmul(kd, r0))
    cc = b.fadd(b.fadd(b.fmul(o[0], o[0]), b.fmul(o[1], o[1])), b.fmul(r0, r0))
    disc = b.fadd(b.fmul(bb, bb), b.fmul(a, cc))
    b.test(a)
    s0, s1 = _quadratic_roots(b, a, bb, cc, disc)
    _after_test(b, _cone_pick(b, tc, o[2], d[2], s0, s1, ln))
    return b.graph("ic_cone", _ic_cone.__doc__)


def _hit_point(b):
    """Keep the nearest candidate (t < best.t or a tie to the lower id), the
    hit point o + t d."""
    b.branch(b.itest(R), b.fadd(R, R))
    return b.madd3(REG3, REG3, R)


def _ic_hit_sphere():
    """IC hit finalisation on a sphere: candidate update, hit point, the
    normal (p - c) normalised with its zero-length guard."""
    b = _Builder()
    p = _hit_point(b)
    c = b.load3(b.int(R))
    n = b.norm3(b.sub3(p, c))
    b.test(b.dot(n, n))
    return b.graph("ic_hit_sphere", _ic_hit_sphere.__doc__)


def _ic_hit_polygon():
    """IC hit finalisation on a polygon: candidate update, hit point, the
    polygon's stored geometric normal (SPD polygons carry no vertex normals)."""
    b = _Builder()
    _hit_point(b)
    adr = b.int(R)
    b.itest(b.load(adr))                            # has_normals
    b.load3(adr)
    return b.graph("ic_hit_polygon", _ic_hit_polygon.__doc__)


def _ic_hit_cone(name):
    def build():
        b = _Builder()
        p = _hit_point(b)
        adr = b.int(R)
        q = b.sub3(p, b.load3(adr))
        u, v, w = b.load3(adr), b.load3(adr), b.load3(adr)
        x, y = b.dot(q, u), b.dot(q, v)
        rho = b.fdiv(b.fadd(b.fmul(x, x), b.fmul(y, y)))
        b.test(rho)
        ir = b.fdiv(rho)
        radial = b.scale3(tuple(b.fadd(b.fmul(u[i], x), b.fmul(v[i], y)) for i in range(3)), ir)
        k = b.fadd(b.load(adr))
        b.norm3(b.madd3(radial, w, k))
        return b.graph(name, build.__doc__)
    build.__doc__ = (f"IC hit finalisation on a {name[7:]}: candidate update, hit point, the "
                     "normal as the gradient radial - k w in the cone's frame, normalised.")
    return build


# ---- SC ----------------------------------------------------------------------

def _sc_shade():
    """SC shade, once per shaded visit (sc_shade): the primitive's material
    (colour, kd, ks, T, ior), the normal turned toward the ray, cos i, the
    ambient term added to the pixel, the surface offset for children, and the
    reflect / refract decisions."""
    b = _Builder()
    m = b.int(b.load(b.int(R)))                      # material index -> address
    rgb = b.load3(m)
    kd, ks, tt = b.load(m), b.load(m), b.load(m)
    dn = b.dot(REG3, REG3)
    sw = b.test(dn)
    b.scale3(REG3, sw)                              # flip the normal
    cosi = b.fadd(dn, sw)
    amb = b.fmul(R, b.load())                       # contrib * ambient
    pix = b.int(R)
    acc = b.load3(pix)
    b.store(b.fadd(acc[0], b.fmul(amb, rgb[0])), pix)
    b.store(b.fadd(acc[1], b.fmul(amb, rgb[1])), pix)
    b.store(b.fadd(acc[2], b.fmul(amb, rgb[2])), pix)
    mx = b.fadd(b.fadd(b.fadd(R), b.fadd(R)), b.fadd(R))
    b.fmul(mx)                                      # surface offset
    b.test(ks)                                      # reflective?
    b.test(tt)                                      # transmissive?
    b.fadd(cosi, kd)
    return b.graph("sc_shade", _sc_shade.__doc__)


def _sc_light():
    """SC work per light, for every light at every shaded hit: the vector to
    the light, its length, the offset test, the unit direction, N.L and the
    luminance term N.L kd contribution."""
    b = _Builder()
    lp = b.load3(b.int(R))
    to = b.sub3(lp, REG3)
    dist = b.fdiv(b.dot(to, to))
    b.test(dist, R)
    inv = b.fdiv(dist)
    to = b.scale3(to, inv)
    ndl = b.dot(REG3, to)
    pos = b.test(ndl)
    b.fmul(b.fmul(b.fadd(ndl, pos), R), R)
    b.int(R)                                        # next light
    b.branch(R)
    return b.graph("sc_light", _sc_light.__doc__)


def _sc_keep():
    """SC threshold decision, per candidate child ray (made or suppressed):
    its contribution against the threshold and the depth limit (keep_child)."""
    b = _Builder()
    c = b.fmul(R, R)
    b.test(c, R)
    b.itest(R)
    return b.graph("sc_keep", _sc_keep.__doc__)


def _new_ray(b):
    """Common to every new ray: its id, kind, depth and pixel."""
    b.int(R)
    b.int(R)


def _sc_shadow():
    """SC per new shadow ray: the light's colour (or the default intensity)
    times the luminance term and the material colour, the ray's range
    (tmin = offset, tmax = distance to the light)."""
    b = _Builder()
    lt = b.load(b.int(R))
    has = b.itest(lt)
    for _ in range(3):
        li = b.load(lt, has)
        b.fmul(li, b.fmul(R, R))
    _new_ray(b)
    return b.graph("sc_shadow", _sc_shadow.__doc__)


def _sc_reflect():
    """SC per new reflection ray: the direction d - 2 (d.n) n normalised,
    contribution times ks."""
    b = _Builder()
    k = b.fmul(b.dot(REG3, REG3))
    b.norm3(b.madd3(REG3, REG3, b.fadd(k)))
    b.fmul(R, R)
    _new_ray(b)
    return b.graph("sc_reflect", _sc_reflect.__doc__)


def _sc_refract():
    """SC per new refraction ray (Snell): eta by the side entered, the
    total-internal-reflection term k, the direction eta d + (eta cos i -
    sqrt k) n normalised, contribution times T."""
    b = _Builder()
    ent = b.itest(R)
    eta = b.fdiv(R, ent)
    c2 = b.fadd(b.fmul(R, R))
    k = b.fadd(b.fmul(b.fmul(eta, eta), c2))
    b.test(k)
    s = b.fadd(b.fmul(eta, R), b.fdiv(k))
    d = tuple(b.fadd(b.fmul(R, eta), b.fmul(R, s)) for _ in range(3))
    b.norm3(d)
    b.fmul(R, R)
    _new_ray(b)
    return b.graph("sc_refract", _sc_refract.__doc__)


def _sc_lit():
    """SC for an unblocked shadow ray arriving from OS: its carried light
    added to the pixel (read, add, write three channels)."""
    b = _Builder()
    pix = b.int(R)
    for _ in range(3):
        b.store(b.fadd(b.load(pix), R), pix)
    return b.graph("sc_lit", _sc_lit.__doc__)


def _sc_primary():
    """SC generating a primary ray (the paper's SC also makes and initialises
    the primary rays): the sample's image-plane offsets, w + sx u + sy v
    normalised, tmin = hither / (d.w), id and pixel."""
    b = _Builder()
    i = b.fadd(b.int(R))
    j = b.fadd(b.int(R))
    sx = b.fmul(b.fadd(i, R), R)
    sy = b.fmul(b.fadd(j, R), R)
    d = tuple(b.fadd(R, b.fadd(b.fmul(R, sx), b.fmul(R, sy))) for _ in range(3))
    d = b.norm3(d)
    b.fdiv(R, b.dot(d, REG3))
    _new_ray(b)
    b.int(R)                                        # next sample
    b.branch(R)
    return b.graph("sc_primary", _sc_primary.__doc__)


# ---- packets -----------------------------------------------------------------

def _send_packet():
    """Packet send overhead, once per packet: room in the send FIFO (read its
    count, compare, branch) and the destination written in the header."""
    b = _Builder()
    b.itest(b.load())
    b.int(R)
    return b.graph("send_packet", _send_packet.__doc__)


def _send_flit():
    """Packet send, per flit: one word written to the send FIFO's port."""
    b = _Builder()
    b.store(R)
    return b.graph("send_flit", _send_flit.__doc__)


def _receive_packet():
    """Packet receive overhead, once per packet: wait for the receive FIFO
    (read its state, branch) and dispatch on the ray kind in the packet."""
    b = _Builder()
    b.itest(b.load())
    b.itest(R)
    return b.graph("receive_packet", _receive_packet.__doc__)


def _receive_flit():
    """Packet receive, per flit: one word read from the receive FIFO's port."""
    b = _Builder()
    b.load()
    return b.graph("receive_flit", _receive_flit.__doc__)


_BUILDERS = (
    ("OS", _os_setup), ("OS", _os_step), ("OS", _os_visit),
    ("IC", _ic_visit), ("IC", _ic_sphere), ("IC", _ic_polygon), ("IC", _ic_vertex),
    ("IC", _ic_cylinder), ("IC", _ic_cone),
    ("IC", _ic_hit_sphere), ("IC", _ic_hit_polygon),
    ("IC", _ic_hit_cone("ic_hit_cylinder")), ("IC", _ic_hit_cone("ic_hit_cone")),
    ("SC", _sc_shade), ("SC", _sc_light), ("SC", _sc_keep), ("SC", _sc_shadow),
    ("SC", _sc_reflect), ("SC", _sc_refract), ("SC", _sc_lit), ("SC", _sc_primary),
    ("any", _send_packet), ("any", _send_flit), ("any", _receive_packet), ("any", _receive_flit),
)

#: every kernel by name
KERNELS: dict = {}
#: the stage whose processor runs each kernel ("any": communication, every stage)
KERNEL_STAGE: dict = {}
for _stage, _build in _BUILDERS:
    _g = _build()
    KERNELS[_g.name] = _g
    KERNEL_STAGE[_g.name] = _stage
del _stage, _build, _g

#: IC test kernel per primitive kind, in the trace's kind order
TEST_KERNELS = ("ic_sphere", "ic_polygon", "ic_cylinder", "ic_cone")
HIT_KERNELS = ("ic_hit_sphere", "ic_hit_polygon", "ic_hit_cylinder", "ic_hit_cone")
