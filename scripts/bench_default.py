"""The default method's time per frame, two antumbra binaries timed in turn (say, a release
build of an older commit and of this one): each renders the six built-in scenes with no method
flags, so each uses its own default, and the renders alternate binary by binary so that both
sides see the same spells of a noisy machine.

    python scripts/bench_default.py OLD_BINARY NEW_BINARY [--frames 1-8] [--size 640x360]
        [--triangles 100000] [--repeat 3] [--threads 1]

A frame's time is the sum over its statistics rows of what the frame did (build, collapse,
visibility, preparation and trace times, from `stats.json`), the best of the repeats per frame;
the table gives the mean over frames per scene and the speed-up.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import tempfile

SCENES = ["bedroom", "city", "colonnade", "forest", "hairball", "indoors"]
# The columns of a statistics row that are time the frame spent (trace_ms of a timed pass).
TIME_COLUMNS = ["build_ms", "visibility_ms", "prepare_ms", "trace_ms"]
# Binaries before protocol 6 called prepare_ms sort_ms.
OLD_NAMES = {"prepare_ms": "sort_ms"}


def frame_times(binary: str, scene: str, args: argparse.Namespace) -> dict[int, float]:
    """Per frame, the sum of the time columns over its rows, for one render."""
    out = tempfile.mkdtemp(prefix=f"bench-default-{scene}-")
    env = dict(os.environ, RAYON_NUM_THREADS=str(args.threads))
    command = [binary, "render", "--scene", scene, "--frames", args.frames, "--size", args.size]
    # Counted (auto learns from counts, as a default render does), then timed: trace_ms is the
    # timed pass.
    command += ["--triangles", str(args.triangles), "--timing", "on", "--out", out]
    subprocess.run(command, check=True, env=env, stdout=subprocess.DEVNULL)
    with open(os.path.join(out, "stats.json")) as f:
        rows = json.load(f)
    times: dict[int, float] = {}
    for row in rows:
        spent = sum(float(row.get(c) or row.get(OLD_NAMES.get(c, c)) or 0.0) for c in TIME_COLUMNS)
        times[row["frame"]] = times.get(row["frame"], 0.0) + spent
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("old")
    parser.add_argument("new")
    parser.add_argument("--frames", default="1-8")
    parser.add_argument("--size", default="640x360")
    parser.add_argument("--triangles", type=int, default=100_000)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--scenes", nargs="*", default=SCENES)
    args = parser.parse_args()
    print("| scene | old ms per frame | new ms per frame | speed-up |")
    print("|---|---:|---:|---:|")
    for scene in args.scenes:
        best: dict[str, dict[int, float]] = {"old": {}, "new": {}}
        for _ in range(args.repeat):
            for side in ("old", "new"):
                for frame, ms in frame_times(getattr(args, side), scene, args).items():
                    best[side][frame] = min(ms, best[side].get(frame, float("inf")))
        old = sum(best["old"].values()) / len(best["old"])
        new = sum(best["new"].values()) / len(best["new"])
        print(f"| {scene} | {old:.1f} | {new:.1f} | {old / new:.2f}x |", flush=True)


if __name__ == "__main__":
    main()
