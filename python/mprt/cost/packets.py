"""Ray packets on the ring: one header flit, data flits, one tail flit.

A flit is 4 bytes, the ring's link width (digest, section 3); a data word is
one flit: single-precision floats, 32-bit integers, small fields packed.  The
data are what the receiving stage needs and what it must pass on, since no
stage keeps per-ray state between visits (OS and IC work on other rays while
one is in flight):

    ray       origin 3, direction 3, tmin 1, tmax 1, pixel 1,
              id / kind / depth packed 1                               = 10
    carry     primary and secondary rays: contribution 1;
              shadow rays: the light term (r, g, b) 3
    shear     the watertight polygon test's shear rows mx, my, made once per
              ray by OS set-up (as mprt__ray_prepare does)              =  6
    walk      3DDDA state OS needs back after a return: cell (i, j, k packed) 1,
              next crossing t per axis 3, crossing spacing 3, t_end 1,
              the voxel's exit t (IC accepts a hit only before it) 1    =  9
    voxel     the voxel id handed to IC                                  =  1
    candidate primary and secondary rays: the nearest hit found so far
              (t, primitive), kept across voxels for grid independence  =  2
    hit       direction 3, contribution 1, pixel 1, id / kind / depth 1,
              hit point 3, normal 3, primitive 1                         = 13
    lit       pixel 1, id / kind 1, light term 3                         =  5
"""
from __future__ import annotations

from .errors import CostModelError

STAGES = ("OS", "IC", "SC")
RAY_KINDS = ("primary", "reflect", "refract", "shadow")
HEADER_FLITS = 1
TAIL_FLITS = 1

RAY = 10
SHEAR = 6
WALK = 9
VOXEL = 1
CANDIDATE = 2
HIT = 13
LIT = 5


def _carry(kind):
    return 3 if kind == "shadow" else 1


def _data_words(src, dst, kind):
    """Data words of a packet, or None when the flow does not exist for the kind."""
    shadow = kind == "shadow"
    if (src, dst) == ("SC", "OS"):            # a new ray (primary rays too: SC makes them)
        return RAY + _carry(kind)
    if (src, dst) in (("OS", "IC"), ("IC", "OS")):   # a ray in its walk, or a return
        return RAY + _carry(kind) + SHEAR + WALK + VOXEL + (0 if shadow else CANDIDATE)
    if (src, dst) == ("IC", "SC"):            # a hit: IC found it and finalised it
        return None if shadow else HIT
    if (src, dst) == ("OS", "SC"):            # shadow: reached its light; else a late hit
        return LIT if shadow else HIT
    return None


def packet_flits(src, dst, ray_kind) -> int:
    """Header + data + tail flits of one packet from stage src to stage dst
    carrying a ray of the given kind (names or indices)."""
    src, dst, kind = _stage(src, "src"), _stage(dst, "dst"), _kind(ray_kind)
    words = _data_words(src, dst, kind)
    if words is None:
        raise CostModelError(f"packet_flits: no {src}->{dst} flow for a {kind} ray")
    return HEADER_FLITS + words + TAIL_FLITS


def _stage(s, what):
    if isinstance(s, str) and s in STAGES:
        return s
    if isinstance(s, int) and not isinstance(s, bool) and 0 <= s < 3:
        return STAGES[s]
    raise CostModelError(f"packet_flits: {what} must be one of {STAGES} or 0..2, not {s!r}")


def _kind(k):
    if isinstance(k, str) and k in RAY_KINDS:
        return k
    if not isinstance(k, bool) and isinstance(k, int) and 0 <= k < 4:
        return RAY_KINDS[k]
    raise CostModelError(f"packet_flits: ray_kind must be one of {RAY_KINDS} or 0..3, not {k!r}")
