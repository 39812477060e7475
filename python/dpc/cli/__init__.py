"""The ``dpc`` command line: list, generate, analyze, compare, mask, dither, stipple (one module each;
``options`` holds the options they share, ``sources`` reads and generates their points).

UTK-style short flags: -m model (in mask and dither: the mask's source, a model or baseline;
--mask is still accepted there), -n points (mask, dither: pixels per side), -d dims, -s seed,
-c sets, -i input, -o output.
Models are bundled names (``dpc list``; more in the folders of $DPC_MODEL_PATH) or ``.onnx``
paths, in every command. Errors print one line ``dpc: error: ...`` and exit with 2 (bad usage)
or 1 (anything else); set DPC_DEBUG=1 to get the traceback instead. Ctrl-C stops any command
at once (exit 130). Every file is written atomically and a command that fails or is
interrupted leaves no output behind and every existing file as it was (``dpc._atomic``).
"""

from __future__ import annotations

import os

import click

from ..errors import DpcError
from .analyze import analyze_cmd
from .compare import compare_cmd
from .dither import dither_cmd
from .generate import generate_cmd
from .list_ import list_cmd
from .mask import mask_cmd
from .options import DISC_DEFAULT as _DISC_DEFAULT  # noqa: F401 (tests hold it to dpc.analysis's list)
from .options import one_line
from .stipple import stipple_cmd

__all__ = ["cli", "main"]

_NO_ARGS_HELP = getattr(click.exceptions, "NoArgsIsHelpError", ())


@click.group(context_settings={"help_option_names": ["-h", "--help"], "max_content_width": 100})
@click.version_option(version=None, package_name="deep-point-correlation", prog_name="dpc")
def cli():
    """dpc: point patterns from Deep Point Correlation Design (Leimkuehler et al. 2019)."""


for _command in (list_cmd, generate_cmd, analyze_cmd, compare_cmd, mask_cmd, dither_cmd, stipple_cmd):
    cli.add_command(_command)


def main(argv=None) -> int:
    """Console entry point: runs the CLI and turns every error into one line + exit code."""
    debug = os.environ.get("DPC_DEBUG", "") not in ("", "0")
    try:
        rv = cli.main(args=argv, prog_name="dpc", standalone_mode=False)
    except _NO_ARGS_HELP as e:  # bare 'dpc' (click >= 8.2): show the help
        click.echo(e.ctx.get_help())
        return 0
    except click.UsageError as e:
        hint = f" (see '{e.ctx.command_path} --help')" if e.ctx is not None else ""
        click.echo(f"dpc: error: {one_line(e.format_message())}{hint}", err=True)
        return 2
    except click.ClickException as e:
        click.echo(f"dpc: error: {one_line(e.format_message())}", err=True)
        return 1 if e.exit_code in (0, None) else e.exit_code
    except (click.exceptions.Abort, KeyboardInterrupt):
        click.echo("dpc: interrupted", err=True)
        return 130
    except (DpcError, OSError, ValueError, MemoryError) as e:
        if debug:
            raise
        msg = str(e)
        if isinstance(e, OSError) and not isinstance(e, DpcError) and e.strerror:
            msg = e.strerror + (f": {e.filename}" if e.filename else "")  # no "[Errno 28]"
        click.echo(f"dpc: error: {one_line(msg) or type(e).__name__}", err=True)
        return 1
    except Exception as e:  # a bug, not bad input: still one line, and how to see more
        if debug:
            raise
        click.echo(
            f"dpc: error: internal error ({type(e).__name__}: {one_line(e)}); rerun with DPC_DEBUG=1 "
            "for the traceback and please report it",
            err=True,
        )
        return 1
    return rv if isinstance(rv, int) else 0
