"""The kernels of the three processors, each described once as an operation graph.

The graph vocabulary (operation classes, Graph, the builder) is in graph.py;
the IC kernels are in kernels_ic.py; OS, SC and packet kernels are here."""
from __future__ import annotations

from .graph import OP_CLASSES, R, REG3, Graph, _Builder  # noqa: F401
from .kernels_ic import (_ic_cone, _ic_cylinder, _ic_hit_cone, _ic_hit_polygon, _ic_hit_sphere, _ic_polygon,
                         _ic_sphere, _ic_vertex, _ic_visit)


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
