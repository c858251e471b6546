"""The ``adaptid`` command: ``demo``, ``fit``, ``fleet`` and ``info`` (typer + rich).

Errors in the user's input end the command with one line
``adaptid: error: <message>`` on stderr and exit code 2 (a traceback is
printed before it only with ``--debug``); typer's own usage errors exit 2 too.
"""

import sys
import traceback
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Optional

import typer
from typer.core import TyperGroup, TyperOption

try:  # typer >= 0.20 vendors click as typer._click
    from typer._click import exceptions as _clickx
except ImportError:  # pragma: no cover - older typer with click
    from click import exceptions as _clickx

from ._errors import CLIError
from ._output import Output

__all__ = ["app", "main"]


class _OneLineErrors(TyperGroup):
    """Usage errors (mistyped option, missing argument, bad value) as one line, exit 2.

    Instead of typer's boxed message: ``adaptid: error: <command>: <message>``
    on stderr, like every other error of the command line.
    """

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        try:
            rv = super().main(args=args, prog_name=prog_name, complete_var=complete_var,
                              standalone_mode=False, **extra)
        except _clickx.NoArgsIsHelpError as err:
            err.show()
            rv = err.exit_code
        except _clickx.ClickException as err:
            msg = " ".join(err.format_message().split())
            ctx = getattr(err, "ctx", None)
            where = ctx.command_path if ctx is not None else "adaptid"
            sys.stdout.flush()
            print(f"adaptid: error: {where}: {msg}", file=sys.stderr)
            sys.stderr.flush()
            rv = err.exit_code
        except _clickx.Abort:
            print("adaptid: interrupted", file=sys.stderr)
            rv = 130
        if not standalone_mode:
            return rv
        sys.exit(rv if isinstance(rv, int) else 0)


def _no_flag_metavar():
    """Flags (``--json``, ``--dc-motor``, ...) take no value: show no ``<bool>`` in --help.

    typer labels every option with its type; for an on/off flag that label
    suggests a value to type. Wrapped once, for this process's help output.
    """
    if getattr(TyperOption.display_type_rich, "_adaptid", False):
        return
    original = TyperOption.display_type_rich

    def display_type_rich(self, ctx):
        if getattr(self, "is_flag", False) and getattr(self, "is_bool_flag", True):
            return None
        return original(self, ctx)

    display_type_rich._adaptid = True
    TyperOption.display_type_rich = display_type_rich


_no_flag_metavar()

app = typer.Typer(
    cls=_OneLineErrors,
    name="adaptid",
    help="Least-squares parameter identification from the shell: `adaptid demo` identifies a "
         "simulated DC motor, `adaptid fit DATA` a model of your data, `adaptid info` reports "
         "the installation.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)

QuietOpt = Annotated[bool, typer.Option("--quiet", "-q", help="Print nothing but errors (and --json).")]
VerboseOpt = Annotated[bool, typer.Option("--verbose", "-v", help="Print more detail.")]
DebugOpt = Annotated[bool, typer.Option("--debug", help="Show the traceback of an error.")]
JsonOpt = Annotated[bool, typer.Option("--json", help="Print only one JSON object on stdout.")]


def _version_callback(value: bool):
    if value:
        from adaptid import __version__
        print(f"adaptid {__version__}")
        raise typer.Exit(0)


@app.callback()
def _global(
    ctx: typer.Context,
    quiet: QuietOpt = False,
    verbose: VerboseOpt = False,
    debug: DebugOpt = False,
    version: Annotated[Optional[bool], typer.Option(
        "--version", callback=_version_callback, is_eager=True, help="Print the version and exit.")] = None,
):
    """Least-squares parameter identification (RLS, sliding window, Kalman, batch)."""
    ctx.obj = Output(quiet=quiet, verbose=verbose, debug=debug)


def _output(ctx: typer.Context, quiet=False, verbose=False, debug=False, json=False) -> Output:
    base = ctx.obj if isinstance(ctx.obj, Output) else Output()
    out = Output(quiet=base.quiet or quiet, verbose=base.verbose or verbose,
                 debug=base.debug or debug, json=json)
    if out.quiet and out.verbose:
        _fail("--quiet and --verbose cannot be combined", out)
    return out


def _fail(message: str, out: Output, code: int = 2):
    line = " ".join(str(message).split())
    sys.stdout.flush()
    print(f"adaptid: error: {line}", file=sys.stderr)
    sys.stderr.flush()
    raise typer.Exit(code)


@contextmanager
def _generic_kernels():
    """A shell command is one short process, mostly compile time: its estimators use the
    size-generic kernels (one compilation for every model order, same results)."""
    from ..estimators import size_generic_kernels

    with size_generic_kernels():
        yield


@contextmanager
def _terminate_as_interrupt():
    """SIGTERM raises KeyboardInterrupt while a command runs (main thread only).

    The default action of SIGTERM ends the process at once, so ``finally``
    blocks never run and temporary files (``.tracks.csv.<pid>.tmp``, a
    report's staging folder, a state's temporary file) stay behind.
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    try:
        previous = signal.signal(signal.SIGTERM, interrupt)
    except (ValueError, OSError):  # pragma: no cover - no signals here
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextmanager
def _guard(out: Output):
    """Turn every exception into one line on stderr (plus a traceback with --debug).

    Whatever ends the command early (an error, Ctrl-C, SIGTERM) first removes
    the staging folders of unfinished reports: outputs appear whole or not at all.
    """
    try:
        with _terminate_as_interrupt():
            try:
                yield
            except BaseException:
                from ._report import discard_open_reports

                discard_open_reports()
                raise
    except (typer.Exit, typer.Abort):
        raise
    except CLIError as err:
        if out.debug:
            traceback.print_exc()
        _fail(str(err), out, 2)
    except KeyboardInterrupt:
        print("adaptid: interrupted", file=sys.stderr)
        raise typer.Exit(130) from None
    except (ValueError, TypeError, OSError, MemoryError) as err:
        if out.debug:
            traceback.print_exc()
        _fail(f"{type(err).__name__}: {err}" if not isinstance(err, ValueError) else str(err), out, 2)
    except Exception as err:  # noqa: BLE001 - a bug: still one line, exit 1
        if out.debug:
            traceback.print_exc()
        _fail(f"internal error ({type(err).__name__}: {err}); run with --debug for the traceback",
              out, 1)


# --------------------------------------------------------------------- demo
@app.command()
def demo(
    ctx: typer.Context,
    out_dir: Annotated[Path, typer.Option("--out", "-o", help="Report folder.")] = Path("adaptid-report"),
    seed: Annotated[int, typer.Option(help="Seed of the simulated data set.")] = 0,
    no_report: Annotated[bool, typer.Option("--no-report", help="Only print the summary table.")] = False,
    json: JsonOpt = False,
    quiet: QuietOpt = False,
    verbose: VerboseOpt = False,
    debug: DebugOpt = False,
):
    """Identify a simulated DC motor (R, L, Ke, J, B, Kt, friction) with RLS, the sliding
    window and the Kalman filter side by side; print a summary and write a report."""
    out = _output(ctx, quiet, verbose, debug, json)
    # a shell command is one short process, mostly compile time: generic kernels
    with _guard(out), _generic_kernels():
        from ._demo import run_demo

        result = run_demo(out_dir=None if no_report else out_dir, seed=seed, output=out)
        if out.json:
            out.emit_json(result)


# ---------------------------------------------------------------------- fit
@app.command()
def fit(
    ctx: typer.Context,
    data: Annotated[Path, typer.Argument(help="CSV (.csv, .tsv, .txt, .gz), Parquet (.parquet) or .npz file.",
                                         show_default=False)],
    y: Annotated[Optional[str], typer.Option("--y", help="Output column.", rich_help_panel="Model")] = None,
    phi: Annotated[Optional[str], typer.Option("--phi", help="Regressor columns, comma separated.",
                                               rich_help_panel="Model")] = None,
    u: Annotated[Optional[str], typer.Option("--u", help="Input column(s) for --arx, --fir, "
                                             "--armax, --oe, --bj.",
                                             rich_help_panel="Model")] = None,
    arx: Annotated[Optional[str], typer.Option("--arx", metavar="NA,NB,NK", help="ARX model orders.",
                                               rich_help_panel="Model")] = None,
    fir_: Annotated[Optional[str], typer.Option("--fir", metavar="NB,NK", help="FIR model orders.",
                                                rich_help_panel="Model")] = None,
    ar: Annotated[Optional[str], typer.Option("--ar", metavar="NA", help="AR time-series model "
                                              "A(q)y = e of the --y column.",
                                              rich_help_panel="Model")] = None,
    arma: Annotated[Optional[str], typer.Option("--arma", metavar="NA,NC", help="ARMA time-series "
                                                "model A(q)y = C(q)e (recursive: extended least "
                                                "squares).", rich_help_panel="Model")] = None,
    bj: Annotated[Optional[str], typer.Option("--bj", metavar="NB,NC,ND,NF,NK", help="Box-Jenkins "
                                              "model y = B/F u + C/D e, the orders for every --u "
                                              "input (recursive: pseudo-linear regression).",
                                              rich_help_panel="Model")] = None,
    armax: Annotated[Optional[str], typer.Option("--armax", metavar="NA,NB,NC,NK", help="ARMAX "
                                                 "model A y = B u + C e, the orders for every --u "
                                                 "input (recursive: extended least squares).",
                                                 rich_help_panel="Model")] = None,
    oe: Annotated[Optional[str], typer.Option("--oe", metavar="NB,NF,NK", help="Output-error model "
                                              "y = B/F u + e, the orders for every --u input "
                                              "(recursive: pseudo-linear regression).",
                                              rich_help_panel="Model")] = None,
    dt: Annotated[Optional[float], typer.Option("--dt", metavar="SECONDS", help="Sample time of "
                                                "the model (default: the step of the --time "
                                                "column, else 1; must agree with it).",
                                                rich_help_panel="Model")] = None,
    intercept: Annotated[bool, typer.Option("--intercept", help="--arx/--fir: add a constant "
                                            "parameter (regressor 1), named 'intercept'.",
                                            rich_help_panel="Model")] = False,
    detrend: Annotated[Optional[str], typer.Option("--detrend", metavar="constant|linear",
                                                   help="Remove each signal's mean or straight "
                                                   "line first (adaptid.IDData.detrend); with "
                                                   "--validate, each part on its own.",
                                                   rich_help_panel="Workflow")] = None,
    validate: Annotated[Optional[float], typer.Option("--validate", metavar="FRACTION",
                                                      help="Estimate on the first FRACTION of the "
                                                      "record; fit % and residual tests on the "
                                                      "rest.", rich_help_panel="Workflow")] = None,
    summary: Annotated[bool, typer.Option("--summary", help="Print the summary table (stderr, t, "
                                          "p, limits, AIC, BIC, residual tests).",
                                          rich_help_panel="Workflow")] = False,
    tracks: Annotated[Optional[Path], typer.Option("--tracks", metavar="FILE", help="Write the "
                                                   "estimates after each sample, with the time "
                                                   "column (.csv or .parquet).",
                                                   rich_help_panel="Workflow")] = None,
    export_c: Annotated[Optional[Path], typer.Option("--export-c", metavar="DIR", help="Write the "
                                                     "fitted estimator as C99 code (NAME.h, NAME.c) "
                                                     "that continues from the final state.",
                                                     rich_help_panel="Workflow")] = None,
    c_name: Annotated[str, typer.Option("--c-name", help="--export-c: C identifier (file name and "
                                        "prefix).", rich_help_panel="Workflow")] = "rls",
    float32: Annotated[bool, typer.Option("--float32", help="--export-c: single precision.",
                                          rich_help_panel="Workflow")] = False,
    dc_motor: Annotated[bool, typer.Option("--dc-motor", help="DC-motor physics: electrical and mechanical "
                                           "equations from time, voltage, current, speed.",
                                           rich_help_panel="Model")] = False,
    time: Annotated[Optional[str], typer.Option("--time", help="Time column (report axis; --dc-motor: "
                                                "default 'time').", rich_help_panel="Model")] = None,
    voltage: Annotated[Optional[str], typer.Option("--voltage", help="--dc-motor voltage column.",
                                                   rich_help_panel="Model")] = None,
    current: Annotated[Optional[str], typer.Option("--current", help="--dc-motor current column.",
                                                   rich_help_panel="Model")] = None,
    speed: Annotated[Optional[str], typer.Option("--speed", help="--dc-motor speed column.",
                                                 rich_help_panel="Model")] = None,
    cutoff: Annotated[Optional[float], typer.Option("--cutoff", help="--dc-motor derivative filter "
                                                    "cut-off (Hz).", rich_help_panel="Model")] = None,
    speed_kind: Annotated[Optional[str], typer.Option("--speed-kind", metavar="sampled|interval_mean",
                                                      help="--dc-motor: speed sampled at the instants "
                                                      "(default) or the mean over the last interval "
                                                      "(differenced encoder counts).",
                                                      rich_help_panel="Model")] = None,
    method: Annotated[Optional[str], typer.Option("--method", "-m",
                                                  metavar="rls|window|kalman|lms|nlms|batch|fastrls",
                                                  help="Estimator. Default: a model option "
                                                  "(--arx, --armax, --oe, --bj, --ar, --arma, "
                                                  "--fir) runs the model's batch fit, unless a "
                                                  "recursive option (--forgetting, --window, "
                                                  "--P0, --tracks, --export-c, --save-state, …) "
                                                  "is given; otherwise rls. fastrls: --fir "
                                                  "with one --u (FastRLS, O(n) per sample).",
                                                  rich_help_panel="Method")] = None,
    forgetting: Annotated[Optional[float], typer.Option("--forgetting", help="λ in (0, 1] (rls, window, "
                                                        "fastrls).",
                                                        rich_help_panel="Method")] = None,
    window: Annotated[Optional[int], typer.Option("--window", help="Window length M (window).",
                                                  rich_help_panel="Method")] = None,
    process_cov: Annotated[Optional[float], typer.Option("--process-cov", help="R1: random-walk "
                                                         "variance per sample (kalman).",
                                                         rich_help_panel="Method")] = None,
    noise_var: Annotated[Optional[float], typer.Option("--noise-var", help="R2: noise variance (kalman).",
                                                       rich_help_panel="Method")] = None,
    p0: Annotated[Optional[str], typer.Option("--P0", help="Prior covariance P0·I (default 1e4), "
                                              "or 'diffuse' for an exact diffuse start (no "
                                              "prior: least squares from the first sample "
                                              "of full rank).",
                                              rich_help_panel="Method")] = None,
    step: Annotated[Optional[float], typer.Option("--step", help="Adaptation gain μ > 0 (lms, nlms).",
                                                  rich_help_panel="Method")] = None,
    eps: Annotated[Optional[float], typer.Option("--eps", help="Normalisation bias ε ≥ 0 (nlms; "
                                                 "default 2.2e-16).", rich_help_panel="Method")] = None,
    delta: Annotated[Optional[float], typer.Option("--delta", help="Soft start δ > 0 of fastrls "
                                                   "(P0 = diag(λ^i)/δ; default 1e-4).",
                                                   rich_help_panel="Method")] = None,
    fastrls_method: Annotated[Optional[str], typer.Option("--fastrls-method", metavar="ftf|lattice",
                                                          help="fastrls algorithm (default ftf).",
                                                          rich_help_panel="Method")] = None,
    nan: Annotated[str, typer.Option("--nan", metavar="raise|skip", help="Rows with missing values "
                                     "(Python's nan_policy): stop with an error (raise; 'error' "
                                     "is accepted as the same) or skip them (counted).")] = "raise",
    out_dir: Annotated[Optional[Path], typer.Option("--out", "-o", help="Folder for the HTML "
                                                    "report (index.html and its figures; "
                                                    "fastrls beyond 8 taps: a heat map of "
                                                    "the tracks).")] = None,
    save_state: Annotated[Optional[Path], typer.Option("--save-state", help="Save the estimator's "
                                                       "state after the run.")] = None,
    resume: Annotated[Optional[Path], typer.Option("--resume", help="Continue from a saved state.")] = None,
    json: JsonOpt = False,
    quiet: QuietOpt = False,
    verbose: VerboseOpt = False,
    debug: DebugOpt = False,
):
    """Identify y = θᵀφ + e from a data file, recursively or in one batch.

    Standard errors of recursive methods are sqrt(σ̂² diag(P)/R2) with
    σ̂² = Σ c_k r_k² / (Σ c_k − n), r_k the residuals of the final estimate and
    c_k each sample's factor in the estimator's cost (adaptid.recursive_fit_stats).
    """
    out = _output(ctx, quiet, verbose, debug, json)
    with _guard(out), _generic_kernels():
        from ._engine import MethodSpec, parse_P0
        from ._fastrls import parse_fir
        from ._fit import run_fit
        from ._problem import Structure, parse_orders, split_names

        structure = Structure(
            y=y, phi=split_names(phi, "--phi"), u=split_names(u, "--u"),
            arx=parse_orders(arx, "--arx", ("na", "nb", "nk")),
            fir=parse_fir(fir_, method),  # --method fastrls: --fir N is N,0
            ar=parse_orders(ar, "--ar", ("na",)), arma=parse_orders(arma, "--arma", ("na", "nc")),
            bj=parse_orders(bj, "--bj", ("nb", "nc", "nd", "nf", "nk")),
            armax=parse_orders(armax, "--armax", ("na", "nb", "nc", "nk")),
            oe=parse_orders(oe, "--oe", ("nb", "nf", "nk")), dt=dt, dc_motor=dc_motor,
            time=time, voltage=voltage, current=current, speed=speed, cutoff=cutoff,
            speed_kind=None if speed_kind is None else speed_kind.strip().lower(),
            intercept=intercept, detrend=None if detrend is None else detrend.strip().lower(),
            validate=validate)
        if method is not None:
            method = method.strip().lower()
        spec = MethodSpec(method=method, forgetting=forgetting, window=window,
                          process_cov=process_cov, noise_var=noise_var,
                          P0=parse_P0(p0), step=step, eps=eps, delta=delta,
                          fastrls_method=None if fastrls_method is None
                          else fastrls_method.strip().lower())
        from ._fastrls import run_fastrls, wants_fastrls

        # issue 38: FastRLS runs on the delay line of u, not on a fixed Φ
        run = run_fastrls if wants_fastrls(spec, resume) else run_fit
        # the run prints (and emits --json) itself, before it saves the state
        run(data, structure, spec, nan=nan.strip().lower(), out=out_dir,
            save_state=save_state, resume=resume, output=out, tracks=tracks,
            summary=summary, export_c=export_c, c_name=c_name, float32=float32)


# -------------------------------------------------------------------- fleet
@app.command()
def fleet(
    ctx: typer.Context,
    data: Annotated[str, typer.Argument(help="Parquet file, folder or glob (or a CSV file), "
                                        "long format: one row per sample.", show_default=False)],
    group: Annotated[str, typer.Option("--group", "-g", help="Device-id column.")],
    y: Annotated[Optional[str], typer.Option("--y", help="Output column.")] = None,
    phi: Annotated[Optional[str], typer.Option("--phi", help="Regressor columns, comma separated.")] = None,
    model: Annotated[Optional[str], typer.Option("--model", metavar="PKG.MOD:CALLABLE",
                                                 help="A callable mapping one device's rows to a "
                                                 "Regression (instead of --y/--phi).")] = None,
    time: Annotated[Optional[str], typer.Option("--time", help="Ordering column (rows sorted by it "
                                                "within each device; default: stored order).")] = None,
    u: Annotated[Optional[str], typer.Option("--u", help="Input column(s) of a model option.",
                                             rich_help_panel="Model")] = None,
    arx: Annotated[Optional[str], typer.Option("--arx", metavar="NA,NB,NK", help="ARX model orders "
                                               "(as adaptid fit).", rich_help_panel="Model")] = None,
    fir_: Annotated[Optional[str], typer.Option("--fir", metavar="NB,NK", help="FIR model orders.",
                                                rich_help_panel="Model")] = None,
    ar: Annotated[Optional[str], typer.Option("--ar", metavar="NA", help="AR model order.",
                                              rich_help_panel="Model")] = None,
    arma: Annotated[Optional[str], typer.Option("--arma", metavar="NA,NC", help="ARMA orders "
                                                "(as adaptid fit).", rich_help_panel="Model")] = None,
    armax: Annotated[Optional[str], typer.Option("--armax", metavar="NA,NB,NC,NK", help="ARMAX "
                                                 "orders (as adaptid fit).", rich_help_panel="Model")] = None,
    oe: Annotated[Optional[str], typer.Option("--oe", metavar="NB,NF,NK", help="Output-error orders "
                                              "(as adaptid fit).", rich_help_panel="Model")] = None,
    bj: Annotated[Optional[str], typer.Option("--bj", metavar="NB,NC,ND,NF,NK", help="Box-Jenkins "
                                              "orders (as adaptid fit).", rich_help_panel="Model")] = None,
    dt: Annotated[Optional[float], typer.Option("--dt", metavar="SECONDS", help="Sample time of the "
                                                "models (default 1).", rich_help_panel="Model")] = None,
    method: Annotated[Optional[str], typer.Option(
        "--method", "-m", metavar="rls|window|kalman|lms|nlms|batch",
        help="Estimator (default rls; with a model option: the model's batch fit per device, "
             "as adaptid fit).")] = None,
    forgetting: Annotated[Optional[float], typer.Option("--forgetting", help="λ in (0, 1].")] = None,
    window: Annotated[Optional[int], typer.Option("--window", help="Window length M.")] = None,
    process_cov: Annotated[Optional[float], typer.Option("--process-cov", help="R1 (kalman).")] = None,
    noise_var: Annotated[Optional[float], typer.Option("--noise-var", help="R2 (kalman).")] = None,
    p0: Annotated[Optional[str], typer.Option("--P0", help="Prior covariance P0·I, or "
                                              "'diffuse' (exact diffuse start).")] = None,
    step: Annotated[Optional[float], typer.Option("--step", help="Adaptation gain μ (lms, nlms).")] = None,
    eps: Annotated[Optional[float], typer.Option("--eps", help="Normalisation bias ε (nlms).")] = None,
    alpha: Annotated[float, typer.Option("--alpha", help="Level of the change test: the fleet's "
                                         "false discovery rate with --multiple bh.")] = 0.05,
    change_test: Annotated[str, typer.Option("--change-test", metavar="supF|re|cusum|cusum2|a-priori",
                                             help="Per-device change test: supF (Andrews; sees "
                                             "coefficient changes, dates the break), re "
                                             "(fluctuation of recursive estimates), cusum, cusum2 "
                                             "(CUSUM of squares), a-priori (BDE CUSUM of the "
                                             "estimator's errors, no p-value).")] = "supF",
    multiple: Annotated[str, typer.Option("--multiple", metavar="bh|bonferroni|none",
                                          help="Control across devices: Benjamini-Hochberg FDR, "
                                          "Bonferroni (alpha/G) or none.")] = "bh",
    nan: Annotated[str, typer.Option("--nan", metavar="raise|skip", help="Rows with missing "
                                     "values (Python's nan_policy; 'error' is the same as "
                                     "raise).")] = "raise",
    scheduler: Annotated[Optional[str], typer.Option("--scheduler", help="Dask scheduler address, "
                                                     "or 'local' to start a LocalCluster "
                                                     "(default: in-process).")] = None,
    tracks: Annotated[Optional[Path], typer.Option("--tracks", help="Folder for per-sample "
                                                   "estimates (Parquet, partitioned by device).")] = None,
    output: Annotated[Optional[Path], typer.Option("--out", "--output", "-o", help="Write the "
                                                   "per-device table (.csv, .parquet or .json); "
                                                   "--output is the former spelling.")] = None,
    json: JsonOpt = False,
    quiet: QuietOpt = False,
    verbose: VerboseOpt = False,
    debug: DebugOpt = False,
):
    """Identify every device of a fleet with the same model and estimator (on Dask);
    one row of results per device, with a change flag and the break date."""
    out = _output(ctx, quiet, verbose, debug, json)
    with _guard(out):
        nan_policy = {"skip": "skip", "error": "raise", "raise": "raise"}.get(nan.strip().lower())
        if nan_policy is None:
            raise CLIError(f"--nan must be raise or skip (error: the same as raise), got {nan!r}")
        from ._engine import check_gradient, check_ranges, parse_P0
        from ._fleetmodel import fleet_method

        p0 = parse_P0(p0)
        structure, method = fleet_method(
            y=y, u=u, phi=phi, model=model, dt=dt, method=method,
            orders={"arx": arx, "fir": fir_, "ar": ar, "arma": arma, "armax": armax, "oe": oe,
                    "bj": bj},
            given={"--forgetting": forgetting, "--window": window, "--process-cov": process_cov,
                   "--noise-var": noise_var, "--P0": p0, "--step": step, "--eps": eps,
                   "--tracks": tracks})
        from ._fleet import check_outputs, fleet_command, summary_text, write_result

        check_ranges(forgetting=forgetting, P0=p0, process_cov=process_cov, noise_var=noise_var)
        if method != "batch":
            check_gradient(method, step, eps, p0)
        tests = {t.lower(): t for t in ("supF", "re", "cusum", "cusum2", "a-priori")}
        if change_test.strip().lower() not in tests:
            raise CLIError(f"--change-test must be one of {', '.join(tests.values())}, "
                           f"got {change_test!r}")
        if multiple.strip().lower() not in ("bh", "bonferroni", "none"):
            raise CLIError(f"--multiple must be bh, bonferroni or none, got {multiple!r}")
        check_outputs(data, output, tracks)
        result = fleet_command(data, group, y=y, phi=phi, model=model,
                               method=method, time=time, scheduler=scheduler, structure=structure,
                               tracks=None if tracks is None else str(tracks),
                               forgetting=forgetting, window=window, process_cov=process_cov,
                               noise_var=noise_var, P0=p0, step=step, eps=eps, alpha=alpha,
                               nan_policy=nan_policy,
                               change_test=tests[change_test.strip().lower()],
                               multiple=multiple.strip().lower(),
                               quiet=out.quiet or out.json or not sys.stderr.isatty())
        if output is not None:
            write_result(result, output)
        if out.json:
            out.emit_json({"n_devices": int(len(result)), "method": method,
                           "n_flagged": int(result["change"].sum()) if "change" in result else None,
                           "devices": result.reset_index().to_dict(orient="records")})
        elif out.chatty:
            out.print(summary_text(result))


# --------------------------------------------------------------------- info
@app.command()
def info(
    ctx: typer.Context,
    json: JsonOpt = False,
    quiet: QuietOpt = False,
    verbose: VerboseOpt = False,
    debug: DebugOpt = False,
):
    """Versions of adaptid, Python, NumPy, SciPy, numba; numba's threading layer and target CPU; the kernels compiled at install; installed extras."""
    out = _output(ctx, quiet, verbose, debug, json)
    with _guard(out):
        from ._info import gather_info

        data = gather_info()
        if out.json:
            out.emit_json(data)
            return
        if not out.chatty:
            return
        from ._output import rich_table

        rows = [[label, data[key]] for key, label in (
            ("adaptid", "adaptid"), ("python", "Python"), ("platform", "platform"),
            ("numpy", "NumPy"), ("scipy", "SciPy"), ("numba", "numba"),
            ("numba_threading_layer_config", "numba threading layer (config)"),
            ("numba_threading_layer", "numba threading layer (in use)"),
            ("numba_num_threads", "numba threads"), ("numba_target_cpu", "numba target CPU"),
            ("cpu_count", "CPUs"))]
        aot = data["compiled_at_install"]
        rows.append(["kernels compiled at install",
                     f"{aot['kernels']}, used" if aot["used"] else f"not used: {aot['why_not']}"])
        patches = data["numba_patches"]
        rows.append(["numba patches applied", ", ".join(p["name"] for p in patches if p["applied"])
                     or "none (ADAPTID_NUMBA_PATCHES=0)"])
        if any(not p["applied"] for p in patches):
            rows.append(["numba patches off", ", ".join(p["name"] for p in patches if not p["applied"])])
        if out.verbose:
            rows.append(["executable", data["executable"]])
        out.print(rich_table("adaptid installation", ["item", "value"], rows, left=2,
                             show_header=False))
        out.print(rich_table("optional extras (pip install 'adaptid[EXTRA]')",
                             ["extra", "installed", "missing"],
                             [[name, "yes" if e["installed"] else "no", ", ".join(e["missing"])]
                              for name, e in data["extras"].items()], left=3))


from ._export import register as _register_export  # noqa: E402

_register_export(app, _output, _guard)


def main(argv=None) -> int:
    """Run the command line (``adaptid`` / ``python -m adaptid``); returns the exit code."""
    args = list(sys.argv[1:] if argv is None else argv)
    try:
        app(args=args, prog_name="adaptid", standalone_mode=True)
    except SystemExit as exc:
        code = exc.code
        if code is None:
            return 0
        if isinstance(code, int):
            return code
        print(code, file=sys.stderr)
        return 1
    return 0
