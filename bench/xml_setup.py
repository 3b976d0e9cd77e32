"""Set-up of a Mitsuba XML scene against the same scene as YAML (issue #19: "parsing and set-up of an
XML scene take no longer than the same scene from YAML").

    python -m mcpt.bench.xml_setup [SCENE.xml ...] [--rounds 7]

Each XML (default: a few of bench/scenes-xml) is converted once with ``mcpt convert`` into a
temporary folder; then ``prepare()`` (read, build, pack, compile, upload; the set-up cache off) of
the XML and of the YAML alternate in one process, the first round dropped (program compile and
file cache warm-up), medians of the rest, in CPU seconds of the process (all its threads).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from ..prepare import prepare
from ..scene.mitsuba.convert import convert_file
from .differential import SCENES

DEFAULT = ("cornell-box.xml", "instances-serialized.xml", "textures-meshes.xml", "spheres-metal-glass.xml")


def timed(path: Path) -> float:
    """CPU seconds of this process (all threads): steadier than wall time on a shared machine."""
    t0 = time.process_time()
    p = prepare(path, cache=False)
    seconds = time.process_time() - t0
    p.renderer.release()
    return seconds


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*", type=Path)
    ap.add_argument("--rounds", type=int, default=7)
    a = ap.parse_args(argv)
    scenes = a.scenes or [SCENES / s for s in DEFAULT]
    with tempfile.TemporaryDirectory() as tmp:
        for xml in scenes:
            yml = Path(tmp) / xml.stem / f"{xml.stem}.yaml"
            convert_file(xml, yml)
            t: dict = {"xml": [], "yaml": []}
            for r in range(a.rounds):
                order = ((xml, "xml"), (yml, "yaml")) if r % 2 == 0 else ((yml, "yaml"), (xml, "xml"))
                for path, side in order:
                    t[side].append(timed(path))
            x, y = statistics.median(t["xml"][1:]), statistics.median(t["yaml"][1:])
            print(f"{xml.name:28s} xml {x * 1e3:8.1f} CPU-ms  yaml {y * 1e3:8.1f} CPU-ms  xml/yaml {x / y:.3f}")


if __name__ == "__main__":
    main()
