"""``mcpt convert``: a Mitsuba 3 XML scene in, the equivalent mcpt YAML scene out (issue #19)."""

from __future__ import annotations

import click

from .group import main, reports_errors


@main.command()
@click.argument("scene_file", type=click.Path(dir_okay=False))
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="YAML scene to write (mesh and texture paths relative to its folder).")
@click.option("-D", "defines", multiple=True, metavar="NAME=VALUE",
              help="Set a <default> parameter of the XML, as Mitsuba's -D; repeatable.")
@reports_errors
def convert(scene_file, output, defines):
    """Convert SCENE_FILE (Mitsuba 3 XML) to an mcpt YAML scene; it is validated before writing."""
    from mcpt.scene.mitsuba.convert import convert_file

    n = convert_file(scene_file, output, defines)
    click.echo(f"wrote {output}: {n} meshes", err=True)
