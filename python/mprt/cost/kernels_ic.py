"""The IC kernels (visit, tests per primitive kind, hit finalisation) as operation graphs."""
from __future__ import annotations

from .graph import R, REG3, _Builder  # noqa: F401


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


