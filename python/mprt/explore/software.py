"""Software variables (``software = [...]`` in a space file): chosen per scene, like the
subdivision, while the rest of the machine is one for the workload.  Each scene runs a design with
the choice of their values best for it (every choice replayed, the fastest kept)."""
from __future__ import annotations

from .space import Design


def with_software(design: Design, choice: dict) -> Design:
    """The design with software variables set (``replication.feed`` is the design's feed)."""
    fields = design.to_dict()
    for name, value in choice.items():
        fields[name.split(".")[-1]] = value
    return Design.from_dict(fields, "software")


class Software:
    """The software choices, mixed into the explorer (they run through it)."""

    def variants(self, machine) -> list:
        """The machine with each choice of the space's software variables (a scene takes its best);
        the machine alone where there are none, or where it is fixed (a SystemConfig)."""
        if not self.space.software or not isinstance(machine, Design):
            return [machine]
        return [with_software(machine, choice) for choice in self.space.software_values()]

    def per_scene(self, pairs, level: int, res: str = "low") -> list:
        """Results of (scene index, dims, machine) pairs with each scene's software at its best:
        (Result, the machine as that scene runs it) per pair."""
        expanded, spans = [], []
        for k, dims, m in pairs:
            vs = self.variants(m)
            spans.append((len(expanded), vs))
            expanded += [(k, dims, v) for v in vs]
        got = self.run(expanded, level, res)
        out = []
        for start, vs in spans:
            rows = got[start:start + len(vs)]
            i = min(range(len(vs)), key=lambda j: (rows[j].cycles, j))
            out.append((rows[i], vs[i]))
        return out

    def machine_for(self, k: int, machine):
        """The machine as scene k runs it: with the software its last evaluation chose."""
        got = self.chosen.get(machine.key()) if isinstance(machine, Design) else None
        return got[k] if got else machine


__all__ = ["Software", "with_software"]
