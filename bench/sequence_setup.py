"""Per-frame set-up of a frame sequence against its render time (issue #26's speed target: where
only the camera moves, set-up <= 5 % of a frame's render at 64 spp on the Cornell box).

    python -m mcpt.bench.sequence_setup [--frames 1-6] [--spp 64] [--resolution 256x256] [--json OUT]

Renders ``scenes/cornell-orbit.yaml`` twice in this process: its camera path alone (mesh tracks
removed: the scene is prepared once and each frame sets the camera's uniforms) and as shipped (a
box turns: every frame is prepared again). Per frame: ``setup`` = what the sequence spent before
the passes (the scene at frame N, uniforms or prepare), ``render`` = the passes, ``other`` = wall
less render (set-up, the loop, writing the EXR). The first frame pays the one prepare of the camera
run and is listed apart.
"""

from __future__ import annotations

import argparse
import json
import statistics
import tempfile
from pathlib import Path

from ..render import Options
from ..scene import load_scene
from ..sequence import parse_frames, render_sequence

SCENE = Path(__file__).resolve().parent.parent / "scenes" / "cornell-orbit.yaml"


def run_case(name: str, overrides: tuple, frames: list, spp: int, resolution: tuple) -> dict:
    scene = load_scene(SCENE, overrides=overrides).with_overrides(spp=spp, resolution=resolution)
    with tempfile.TemporaryDirectory() as tmp:
        out = render_sequence(scene, Options([str(Path(tmp) / "f.####.exr")]), frames)
    rows = [{"frame": r.frame, "setup": r.setup_seconds, "render": r.render_seconds,
             "other": r.wall_seconds - r.render_seconds} for r in out.rendered]
    later = rows[1:] or rows
    return {"case": name, "rebuilt_per_frame": out.rebuilt, "frames": rows,
            "setup_share_median": statistics.median(r["setup"] / r["render"] for r in later),
            "other_share_median": statistics.median(r["other"] / r["render"] for r in later)}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", default="1-6")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--resolution", default="256x256")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    frames = parse_frames(a.frames)
    res = tuple(int(v) for v in a.resolution.lower().split("x"))
    cases = [run_case("camera moves", ("animation.meshes=[]",), frames, a.spp, res),
             run_case("camera and a box move", (), frames, a.spp, res)]
    for c in cases:
        print(f"{c['case']} (prepared {'every frame' if c['rebuilt_per_frame'] else 'once'}), "
              f"{a.resolution}, {a.spp} spp:")
        for r in c["frames"]:
            print(f"  frame {r['frame']:>4}: set-up {r['setup'] * 1e3:8.2f} ms  render {r['render']:7.3f} s  "
                  f"other {r['other'] * 1e3:8.2f} ms  set-up/render {100 * r['setup'] / r['render']:6.3f} %")
        print(f"  frames after the first, medians: set-up {100 * c['setup_share_median']:.3f} % of the "
              f"render, everything but the passes {100 * c['other_share_median']:.3f} %")
    if a.json:
        a.json.write_text(json.dumps(cases, indent=1))


if __name__ == "__main__":
    main()
