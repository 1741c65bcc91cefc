#!/usr/bin/env python3
"""Splits a perf profile of a render into the shadow pass's traversal and everything around it.

Reads `perf script --inline -F tid,ip,sym` (a `perf record -e cpu-clock --call-graph dwarf` of a
one-thread render, BENCHMARKS.md) on stdin. A sample belongs to:
  shadow pass   a frame of `ShadowPass::trace` on its stack (its rayon closure included);
  traversal     of those, a frame of the tree's batch query (`RayQuery::occluded_batch`);
  preparation   a frame of `light_tracing` or of the order code it calls (on rayon's workers
                the stack starts below it), with choosing the representative rays
                (`representative_rays` and its parallel scan) counted apart.
Prints the samples of each and the share of the shadow pass spent outside traversal, with its
largest leaf functions.
"""

import collections
import re
import sys

SHADOW = "render::shadow::ShadowPass::trace"
TRAVERSAL = "RayQuery>::occluded_batch"
PREPARATION = ("render::light_tracer::light_tracing", "order::child_sort", "order::prepared")
REPRESENTATIVE = ("render::shadow::representative_rays", "render::shadow::rays_of_pixels")


def samples(lines):
    """Each sample's frames, innermost first."""
    frames = []
    for line in lines:
        if not line.strip():
            if frames:
                yield frames
            frames = []
        elif line.startswith((" ", "\t")):
            parts = line.strip().split(None, 1)
            if len(parts) == 2:
                frames.append(parts[1])
    if frames:
        yield frames


def short(frame):
    """A frame's function name without the inline marker, generics or closures."""
    name = re.sub(r" \(inlined\)$", "", frame)
    return name.replace("antumbra_core::", "")[:90]


def main():
    total = shadow = traversal = prep = representative = 0
    outside = collections.Counter()
    for frames in samples(sys.stdin):
        total += 1
        chosen = any(r in f for f in frames for r in REPRESENTATIVE)
        if chosen or any(p in f for f in frames for p in PREPARATION):
            prep += 1
            representative += chosen
        if not any(SHADOW in f for f in frames):
            continue
        shadow += 1
        if any(TRAVERSAL in f for f in frames):
            traversal += 1
        else:
            # The innermost frame of our own code names where the time went.
            own = next((f for f in frames if "antumbra" in f), frames[0])
            outside[short(own)] += 1

    def pct(n, d):
        return 100.0 * n / max(d, 1)

    print(f"samples {total}")
    print(
        f"shadow pass {shadow}: traversal {traversal}, outside traversal {shadow - traversal} "
        f"({pct(shadow - traversal, shadow):.1f}% of the pass)"
    )
    print(
        f"order preparation {prep} ({pct(prep, shadow):.1f}% of the shadow pass), "
        f"of which choosing representative rays {representative}"
    )
    print("outside traversal, by innermost own frame:")
    for name, n in outside.most_common(12):
        print(f"  {pct(n, shadow):5.1f}%  {name}")


if __name__ == "__main__":
    main()
