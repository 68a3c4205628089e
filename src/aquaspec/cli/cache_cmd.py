"""``aquaspec cache info|clear``: what aquaspec keeps per machine."""

from __future__ import annotations

from aquaspec import cache

_UNITS = ("bytes", "KiB", "MiB", "GiB", "TiB")


def register(sub):
    p = sub.add_parser(
        "cache", help="show or empty the cache of what aquaspec computes once per machine",
        description="aquaspec keeps what it computes once per machine (light-field tables, "
                    f"caustics, colour data) in ${cache.CACHE_ENV} (off: keep nothing), else "
                    "$XDG_CACHE_HOME/aquaspec or ~/.cache/aquaspec, and removes the least "
                    f"recently used files beyond ${cache.MAX_ENV} bytes (suffixes K, M, G, T; "
                    f"default {cache.DEFAULT_MAX}).")
    actions = p.add_subparsers(dest="action", metavar="ACTION", required=True,
                               help="info or clear")
    actions.add_parser("info", help="the cache's directory, files, total size and cap",
                       description="Print the cache's directory, its number of files, their "
                                   "total size and the cap.")
    actions.add_parser("clear", help="remove aquaspec's files from the cache",
                       description="Remove aquaspec's files (.npz) from the cache directory; "
                                   "anything else there is left alone.")
    p.set_defaults(func=run)


def format_size(n_bytes: int) -> str:
    """``n_bytes`` for people: ``"139.2 MiB"`` (powers of 1024, as
    ``$AQUASPEC_CACHE_MAX`` reads them)."""
    k = 0
    while k < len(_UNITS) - 1 and n_bytes >= 1024 ** (k + 1):
        k += 1
    return f"{n_bytes} bytes" if k == 0 else f"{n_bytes / 1024 ** k:.1f} {_UNITS[k]}"


def run(args):
    if args.action == "info":
        info = cache.usage()
        if info.directory is None:
            print(f"directory: none (caching is off: {cache.CACHE_ENV}=off or no home "
                  "directory)")
        else:
            print(f"directory: {info.directory}")
        print(f"files: {info.files}")
        print(f"total size: {format_size(info.size_bytes)}")
        print(f"cap: {format_size(info.cap_bytes)} ({cache.MAX_ENV})")
    else:
        cache.max_bytes()       # a bad $AQUASPEC_CACHE_MAX is reported here too
        directory = cache.cache_dir()
        files, size = cache.clear()
        where = "caching is off" if directory is None else str(directory)
        print(f"removed {files} files ({format_size(size)}) from {where}")
    return 0
