"""Command line: ``ghserver serve``, ``list``, ``fabricate``, ``report``, ``demo``, ``study``.

``python -m ghserver`` and the ``ghserver`` console script both call :func:`main`.
"""
from __future__ import annotations

import argparse
import logging
import signal
import socket
import sys
import threading

from ghserver import report  # importing it does not load matplotlib
from ghserver.study import add_study_parser  # importing it loads neither distributed nor the strategies

log = logging.getLogger("ghserver")

DEFAULT_HOST = "127.0.0.1"
DEFAULT_PORT = 5000
#: ``ghserver fabricate --units``: the short names → Rhino's unit system names (the .3dm's and the DXF's units)
UNIT_NAMES = {"mm": "Millimeters", "cm": "Centimeters", "dm": "Decimeters", "m": "Meters", "km": "Kilometers",
              "in": "Inches", "ft": "Feet", "yd": "Yards"}


def _ipv6_loopback_available() -> bool:
    if not socket.has_ipv6:
        return False
    try:
        with socket.socket(socket.AF_INET6, socket.SOCK_STREAM) as s:
            s.bind(("::1", 0))
        return True
    except OSError:
        return False


def _reuse_port_socket(host: str, port: int) -> socket.socket:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
    sock.bind((host.strip("[]"), port))
    return sock


def make_server(app, host: str = DEFAULT_HOST, port: int = DEFAULT_PORT, threads: int = 8, reuse_port: bool = False,
                **kw):
    """A hardened waitress server (:func:`ghserver.serving.make_server`) for ``app``; on the default loopback
    host it also listens on ``[::1]`` when available.

    Windows resolves ``localhost`` to ``::1`` first, so a Hops path ``http://localhost:5000/…`` stays fast.
    ``reuse_port`` (Linux, BSD, macOS) lets several server processes listen on the same address: the kernel
    spreads connections over them (scale-out without a proxy; components are stateless). Keyword options go to
    :func:`ghserver.serving.make_server` (``max_body_mb``, ``connection_limit``, ``channel_timeout``,
    ``request_timeout``, ...) and on to waitress.
    """
    from ghserver.serving import make_server as serving_server

    kw = dict(kw, threads=threads)
    if reuse_port:
        if not hasattr(socket, "SO_REUSEPORT"):
            raise OSError("--reuse-port is not supported on this platform; run instances behind a reverse proxy")
        return serving_server(app, sockets=[_reuse_port_socket(host, port)], **kw)
    listen = [f"{host}:{port}" if ":" not in host else f"[{host}]:{port}"]
    if host == DEFAULT_HOST and port != 0 and _ipv6_loopback_available():
        listen.append(f"[::1]:{port}")
    try:
        return serving_server(app, listen=" ".join(listen), **kw)
    except OSError:
        if len(listen) > 1:  # IPv6 half failed (port taken on ::1 only): serve IPv4 alone
            return serving_server(app, listen=listen[0], **kw)
        raise


def _is_loopback(host: str) -> bool:
    import ipaddress

    if host in ("localhost",):
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def config_from_args(args):
    """The :class:`ghserver.app.Config` of ``ghserver serve`` options; enforces the bind rules.

    Binding anything but loopback requires an API key (``--api-key`` or ``GHSERVER_API_KEY``) unless
    ``--no-auth`` says explicitly that the network is trusted.
    """
    import os

    from ghserver.app import Config

    api_key = args.api_key or os.environ.get("GHSERVER_API_KEY") or None
    if not _is_loopback(args.host) and not api_key and not args.no_auth:
        raise SystemExit(
            f"refusing to listen on {args.host} without an API key: anyone on the network could run solves. "
            "Pass --api-key KEY (or set GHSERVER_API_KEY; Hops sends it as RhinoComputeKey), or --no-auth on a "
            "trusted network."
        )
    workers = args.workers if args.workers is not None else (os.cpu_count() or 1)
    hosts = tuple(h.strip() for item in (args.allowed_hosts or []) for h in item.split(",") if h.strip())
    return Config(
        max_body_mb=args.max_body_mb, cache_size=args.cache_size, cache_mb=args.cache_mb, report_dir=args.report_dir,
        workers=workers, solve_timeout=args.solve_timeout, memory_limit_mb=args.memory_limit_mb,
        max_vertices=args.max_vertices, max_faces=args.max_faces, max_request_vertices=args.max_request_vertices,
        max_request_faces=args.max_request_faces, max_json_mb=args.max_json_mb, max_response_mb=args.max_response_mb,
        max_queued_mb=args.max_queued_mb,
        max_pending_solves=max(1, args.threads - 4) if workers or args.cluster else 0,
        api_key=api_key, host=args.host, allowed_hosts=hosts, registry_factory=args.components,
        cluster=args.cluster or None, job_timeout=args.job_timeout, job_ttl=args.job_ttl, max_jobs=args.max_jobs,
    )


def _serve(args) -> int:
    from ghserver.app import create_app

    cfg = config_from_args(args)
    refusals: tuple = ()
    if cfg.cluster:
        from ghserver.cluster import ClusterError  # deferred import: loads distributed (~1 s), only --cluster needs it

        refusals = (ClusterError,)
    try:
        app = create_app(cfg)
    except refusals as exc:
        print(f"ghserver serve: {exc}", file=sys.stderr)
        return 2
    n = len(app.extensions["ghserver.registry"])
    try:
        extra = {"connection_limit": args.connection_limit} if args.connection_limit else {}
        server = make_server(app, args.host, args.port, threads=args.threads, reuse_port=args.reuse_port,
                             max_body_mb=args.max_body_mb, channel_timeout=args.channel_timeout,
                             request_timeout=args.request_timeout, **extra)
    except OSError as exc:
        log.error("cannot listen on %s:%s: %s", args.host, args.port, exc)
        return 2
    cap = cfg.worker_memory_mb
    log.info("serving %d components on http://%s:%d/ (threads=%d, solver processes=%d, time limit %g s, "
             "memory cap %s per process, cache=%d/%g MB, body limit %g MB, connections %d%s)", n, args.host,
             args.port, args.threads, cfg.workers if not cfg.cluster else 0, cfg.solve_timeout,
             f"{cap:.0f} MB" if cap else "none",
             args.cache_size, args.cache_mb, args.max_body_mb, server.adj.connection_limit,
             ", API key required" if cfg.api_key else "")
    from components.core import compiled

    log.info("%s", compiled.status())
    if cfg.cluster:
        log.info("solves run on the Dask cluster %s (%d workers now)", cfg.cluster,
                 app.extensions["ghserver.pool"].workers())
    log.info("in Grasshopper: Hops path http://%s:%d/<component>, e.g. http://%s:%d/metrics/planarity",
             args.host, args.port, args.host, args.port)
    stop_on_sigterm()
    try:
        server.run()
    except KeyboardInterrupt:
        pass  # logged by the signal handler
    finally:
        pool = app.extensions.get("ghserver.pool")
        if pool is not None:
            pool.close()
        log.info("stopped")
    return 0


def stop_on_sigterm() -> None:
    """Ctrl+C and SIGTERM (``kill``, service managers, containers) stop the server the same way: logged, the solver
    processes closed, "stopped" logged last."""
    def handler(signum, frame):  # waitress swallows the KeyboardInterrupt, so the reason is logged here
        name = "Ctrl+C" if signum == signal.SIGINT else signal.Signals(signum).name
        log.info("stopping (%s): closing the solver processes", name)
        raise KeyboardInterrupt(name)

    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, getattr(signal, "SIGTERM", None)):
            if sig is not None:
                signal.signal(sig, handler)


class LineSafeHandler(logging.StreamHandler):
    """A log handler that clears the terminal line first, so a record never lands inside a progress bar drawn with
    ``\\r`` (the bar redraws itself on its next step)."""

    def emit(self, record: logging.LogRecord) -> None:
        isatty = getattr(self.stream, "isatty", None)
        if isatty is not None and isatty():
            try:
                self.stream.write("\r\x1b[K")
            except (OSError, ValueError):
                pass
        super().emit(record)


def _list(args) -> int:
    from ghserver.endpoints import build_registry

    reg = build_registry()
    if args.markdown:
        print("| component | inputs | outputs | what it does |")
        print("|---|---|---|---|")
        for c in reg:
            ins = ", ".join(f"`{p.name}`" + ("?" if p.optional else "") for p in c.inputs)
            outs = ", ".join(f"`{p.name}`" for p in c.outputs)
            print(f"| `{c.uri}` | {ins} | {outs} | {c.description.replace('|', '&#124;')} |")
        return 0
    from ghserver.registry import input_summary

    for c in reg:
        print(f"/{c.uri:32s} {c.description}")
        if not args.verbose:
            continue
        # one line per input: kind, access, default (or required/optional), range, choices, description
        width = max(len(p.name) for p in c.inputs + c.outputs)
        print(f"    python: {c.function.__module__}.{c.function.__name__}")
        for head, params in (("in: ", c.inputs), ("out:", c.outputs)):
            for i, p in enumerate(params):
                extra = f", {input_summary(p)}" if params is c.inputs else ""
                print(f"    {head if i == 0 else '    '} {p.name:{width}s}  {p.kind} {p.access}{extra}: {p.description}")
    return 0


# ----------------------------------------------------------------------------------------------
# ghserver fabricate

def _fabricate(args) -> int:
    from pathlib import Path

    import numpy as np

    from components.fabrication.export import fabrication, write_csv, write_dxf
    from ghserver.convert import read_model, write_3dm

    logging.getLogger("ezdxf").setLevel(logging.WARNING)  # its INFO lines describe the DXF file's internals
    path = Path(args.mesh)
    tol = list(args.tolerance or [])
    sheet = args.sheet or (0.0, 0.0)
    try:
        V, F, notes, units = read_model(path, layer=args.layer, name=args.object)
        if args.units is not None:
            if units is not None and units != UNIT_NAMES[args.units]:
                notes += (f"{path.name} is in {units.lower()}: --units {args.units} writes the files in "
                          f"{UNIT_NAMES[args.units].lower()} (the coordinates are not converted)",)
            units = UNIT_NAMES[args.units]
        elif units is None:
            notes += (f"{path.name} does not say its units: the DXF and the .3dm are written unitless (give --units, "
                      "e.g. --units mm, to write them in)",)
        for note in notes:
            print(f"note: {note}")
        fab = fabrication(V, F, tolerance=tol[0] if tol else 0.0, tolerances=tol, mirror=not args.no_mirror,
                          sheet_width=sheet[0], sheet_height=sheet[1], gap=args.gap, method=args.method,
                          axes=args.axes, beam_height=args.beam_height, beam_width=args.beam_width,
                          kink_limit=args.kink_limit, name=path.name)
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        written = [write_dxf(out / f"{path.stem}_panels.dxf", fab, units),
                   write_csv(out / f"{path.stem}_cutting_list.csv", fab),
                   write_3dm(out / f"{path.stem}.3dm", fab, units)]
    except (ValueError, OSError) as exc:  # InputError / MeshError are ValueErrors: a bad file or option
        print(f"ghserver fabricate: {exc}", file=sys.stderr)
        return 2
    flat, types, dh = fab.flat, fab.types, fab.dihedrals
    kink = dh.angle[dh.interior]
    tors = np.abs(fab.frames.torsion)
    lay = fab.layout
    print(f"{path.name}: {len(F):,} panels on {lay.sheet_count} sheet(s) of {lay.sheet_width:.4g} × "
          f"{lay.sheet_height:.4g}, flattening error {flat.length_error.max(initial=0.0):.1e} (relative), "
          f"largest corner residual {np.abs(flat.residual).max(initial=0.0):.3g}")
    mirror = "not allowed" if args.no_mirror else "allowed"
    print(f"panel types at {types.tolerance:.4g}: {len(types.counts)} (mirror {mirror})")
    print("| tolerance | types |")
    print("|---:|---:|")
    for t, n in zip(types.tolerances.tolist(), types.type_counts.tolist()):
        print(f"| {t:.4g} | {n} |")
    if len(kink):
        print(f"kinks: max {kink.max():.3g}°, mean {kink.mean():.3g}°, {int(np.sum(kink > fab.kink_limit))} joints "
              f"over {fab.kink_limit:g}°")
    print(f"nodes: {fab.supports.method} axes ({'conical' if fab.supports.conical else 'not conical'}), "
          f"torsion max {tors.max(initial=0.0):.3g}°, mean {tors.mean() if len(tors) else 0.0:.3g}°")
    for w in fab.warnings:
        print(f"warning: {w}")
    print("wrote " + ", ".join(str(p) for p in written))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="ghserver", description="Planar-quad meshing components for Grasshopper Hops")
    parser.add_argument("--log-level", default="INFO", help="DEBUG, INFO, WARNING (default INFO)")
    sub = parser.add_subparsers(dest="command")
    s = sub.add_parser("serve", help="run the Hops component server")
    s.add_argument("--host", default=DEFAULT_HOST, help=f"address to bind (default {DEFAULT_HOST}, loopback only)")
    s.add_argument("--port", type=int, default=DEFAULT_PORT, help=f"port (default {DEFAULT_PORT})")
    s.add_argument("--threads", type=int, default=16,
                   help="threads answering HTTP requests (default 16; 4 are kept free for metadata requests)")
    s.add_argument("--cache-size", type=int, default=64, help="solved results kept in memory; 0 disables (default 64)")
    s.add_argument("--cache-mb", type=float, default=256, help="... and their total size in MB (default 256)")
    s.add_argument("--max-body-mb", type=float, default=512, help="largest request body in MB (default 512)")
    s.add_argument("--max-json-mb", type=float, default=512,
                   help="largest estimated size of a request's parsed JSON in MB (default 512)")
    s.add_argument("--max-response-mb", type=float, default=256, help="largest answer in MB (default 256)")
    s.add_argument("--max-queued-mb", type=float, default=None,
                   help="request bodies the server process holds at once, in MB (default 2 × --max-body-mb)")
    s.add_argument("--report-dir", default=report.DEFAULT_OUT,
                   help=f"folder whose report.html is served at /report/ (default ./{report.DEFAULT_OUT}, "
                        "where `ghserver demo` writes)")
    s.add_argument("--workers", type=int, default=None,
                   help="solver processes (default: one per core; 0 solves inside the server process)")
    s.add_argument("--solve-timeout", type=float, default=90.0, help="seconds a solve may run (default 90)")
    s.add_argument("--memory-limit-mb", type=float, default=None,
                   help="memory cap per solver process (POSIX; default 60%% of the machine's memory shared by the "
                        "solver processes, at least 1024; 0: none)")
    s.add_argument("--max-vertices", type=int, default=5_000_000, help="largest mesh accepted (default 5e6)")
    s.add_argument("--max-faces", type=int, default=5_000_000, help="largest mesh accepted (default 5e6)")
    s.add_argument("--max-request-vertices", type=int, default=None,
                   help="vertices of all meshes of one request together (default: --max-vertices)")
    s.add_argument("--max-request-faces", type=int, default=None,
                   help="faces of all meshes of one request together (default: --max-faces)")
    s.add_argument("--api-key", default=None, help="require this key on solves (RhinoComputeKey header)")
    s.add_argument("--no-auth", action="store_true", help="allow a non-loopback --host without an API key")
    s.add_argument("--allowed-hosts", action="append", metavar="NAME[,NAME]",
                   help="more host names requests may name (Host and Origin), e.g. a reverse proxy's; '*' turns "
                        "the cross-site check of Host/Origin off (default: loopback names, the bound address)")
    s.add_argument("--connection-limit", type=int, default=None,
                   help="open connections at most (default 1000; 500 on Windows)")
    s.add_argument("--channel-timeout", type=float, default=120.0,
                   help="seconds an idle connection stays open (default 120; 10 once half the limit is in use)")
    s.add_argument("--request-timeout", type=float, default=30.0,
                   help="seconds a request's headers may take to arrive (default 30; bodies at >= 64 kB/s)")
    s.add_argument("--components", default="ghserver.endpoints:build_registry", metavar="MODULE:FUNCTION",
                   help="function returning the component Registry to serve (default: the published components)")
    s.add_argument("--reuse-port", action="store_true",
                   help="share the port with other ghserver processes (scale-out on one address; not on Windows)")
    s.add_argument("--cluster", default=None, metavar="tcp://HOST:PORT",
                   help="run every solve on this Dask scheduler's workers instead of local processes (each worker "
                        "machine needs this project installed; metadata is answered here)")
    s.add_argument("--job-timeout", type=float, default=3600.0,
                   help="seconds a job (POST /jobs/<component>) may run (default 3600)")
    s.add_argument("--job-ttl", type=float, default=600.0,
                   help="seconds a finished job's result is kept (default 600)")
    s.add_argument("--max-jobs", type=int, default=64,
                   help="jobs kept at once, queued, running or finished (default 64; beyond: 429)")
    s.set_defaults(func=_serve)
    r = sub.add_parser("report", help="run every strategy on the built-in surfaces (and mesh files): HTML report")
    report.add_report_arguments(r)
    r.set_defaults(func=report.report_command)
    d = sub.add_parser("demo", help="the comparison report on the built-in surfaces (under 2 minutes)")
    report.add_demo_arguments(d)
    d.set_defaults(func=report.demo_command)
    add_study_parser(sub)  # ghserver study STUDY.toml [--cluster ADDR | --workers N] [--out DIR]
    fb = sub.add_parser("fabricate", help="flat panels on sheets, panel types, kinks, node axes and beams of a "
                                          "panelling: DXF, CSV cutting list and .3dm")
    fb.add_argument("mesh", help="the panelling: a .3dm (one mesh), .stl (welded), .obj, .off or .ply file")
    fb.add_argument("--layer", default=None, help="in a .3dm holding several meshes: the layer to use")
    fb.add_argument("--object", default=None, help="in a .3dm holding several meshes: the object name")
    fb.add_argument("--out", default="fabrication", help="output folder (default ./fabrication)")
    fb.add_argument("--units", choices=sorted(UNIT_NAMES), default=None,
                    help="the model's units, written into the DXF and the .3dm (default: the .3dm's own; an .obj, "
                         ".off, .ply or .stl has none: the files are then written unitless)")
    fb.add_argument("--tolerance", type=float, nargs="+", default=None, metavar="T",
                    help="panel-type tolerance(s) in model units: types at the first, counts at all (default "
                         "1e-3 × the median edge, counts at 1, 2, 5, 10 × it)")
    fb.add_argument("--sheet", type=float, nargs=2, default=None, metavar=("W", "H"),
                    help="sheet width and height in model units (default: one sheet, about square)")
    fb.add_argument("--gap", type=float, default=0.0, help="gap between panels on the sheets (model units)")
    fb.add_argument("--no-mirror", action="store_true", help="a panel and its mirror image are different types")
    fb.add_argument("--method", choices=("project", "unfold"), default="project",
                    help="flattening of warped panels (default project)")
    fb.add_argument("--axes", choices=("auto", "offset", "normals"), default="auto",
                    help="node axes (default: offset axes of a conical mesh, else face normals)")
    fb.add_argument("--beam-height", type=float, default=0.0, help="beam depth (default 0.2 × the mean edge)")
    fb.add_argument("--beam-width", type=float, default=0.0, help="beam width (default 0.05 × the mean edge)")
    fb.add_argument("--kink-limit", type=float, default=10.0, help="joints kinking more are counted (degrees)")
    fb.set_defaults(func=_fabricate)
    ls = sub.add_parser("list", help="print the component catalogue")
    ls.add_argument("-v", "--verbose", action="store_true",
                    help="also list inputs (kind, access, default, range, choices) and outputs")
    ls.add_argument("--markdown", action="store_true", help="a Markdown table (the one in README.md)")
    ls.set_defaults(func=_list)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    logging.basicConfig(level=getattr(logging, str(args.log_level).upper(), logging.INFO),
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s", handlers=[LineSafeHandler()])
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    return args.func(args)


if __name__ == "__main__":
    sys.exit(main())
