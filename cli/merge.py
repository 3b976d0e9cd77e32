"""``mcpt merge A.exr B.exr ... -o OUT.exr``: renders of one scene with different seeds, combined
into the image one render of the summed spp would give (mcpt/farm/merge.py)."""

from __future__ import annotations

import os

import click

from .group import main, reports_errors


def _same_file(a, b) -> bool:
    """The same file, however named (relative, absolute, a link)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one does not exist: the same only if the names resolve alike
        return os.path.realpath(a) == os.path.realpath(b)


@main.command()
@click.argument("inputs", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("-o", "--output", "outputs", multiple=True, required=True,
              help="Merged image (.exr, or .png for a preview); repeat for several.")
@click.option("--exposure", type=float, default=0.0, show_default=True, help="PNG only: stops.")
@click.option("--denoise", is_flag=True,
              help="Denoise the merged beauty with OIDN (biased; needs the albedo and normal layers "
                   "in every input and mcpt[denoise]); the raw merge is kept as raw.R/G/B.")
@reports_errors
def merge(inputs, outputs, exposure, denoise):
    """Merge EXR renders of the same scene (different seeds), weighted by their spp, AOV layers
    included."""
    from mcpt.farm.merge import merge as merge_images
    from mcpt.farm.signals import StopSignals
    from mcpt.output.image import check_output_path, write_images

    for output in outputs:
        check_output_path(output)
        if any(_same_file(output, i) for i in inputs):
            raise click.BadParameter(f"{output} is also an input: merge would replace it (issue "
                                     "#24); name another output", param_hint="-o")
    # A stop signal acts at once (issue #24: SIGTERM during the write left the temporary file):
    # nothing is written until the merge is done, and a write in progress is undone.
    with StopSignals() as signals, signals.writing():
        image, header, layers = merge_images(list(inputs), denoise=denoise)
        write_images(outputs, image, header, exposure, layers)
    notes = [f"layers {header['mcpt:aovs']}"] if header.get("mcpt:aovs") else []
    if "mcpt:merged_beauty" in header:
        notes.append("the inputs were denoised: their raw beauty was merged"
                     + ("" if denoise else " (--denoise denoises the merge)"))
    if denoise:
        notes.append("denoised (biased)")
    click.echo(f"wrote {', '.join(outputs)}: {len(inputs)} renders, {header['mcpt:spp']} spp "
               f"(seeds {header['mcpt:seeds']})" + "".join(f"; {n}" for n in notes), err=True)
