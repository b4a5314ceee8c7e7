"""Archive a slice of a sweep's results folder into docs/results (reproduction.md, "How it was run").

    python docs/sweeps/archive_runs.py RESULTS docs/results/runs_NAME.csv --expect 15 \\
        --where dataset=intersection-3,intersection-4,intersection-5 model=proposed training=end-to-end \\
        loss=dice matching_score=mse

Prints ``synthcal table RESULTS --layout runs --format csv`` (the runs archive of the whole folder), keeps the
finished runs whose keys take one of the listed values (``KEY=V1,V2``), checks there are ``--expect`` of them, and
writes them to OUT — after OUT's own rows when it exists (a session's slice appended to an archive), a run already
there kept once. The write is atomic: a temporary file beside OUT, then a rename. ``--synthcal`` names the CLI to
print with (the sweep's frozen clone's, by default the one on PATH).
"""

from __future__ import annotations

import argparse
import io
import os
import subprocess
from pathlib import Path

import pandas as pd


def conditions(pairs: list[str]) -> dict[str, list[str]]:
    """``["loss=dice", "dataset=a,b"]`` → ``{"loss": ["dice"], "dataset": ["a", "b"]}``."""
    parsed = {}
    for pair in pairs:
        key, sep, values = pair.partition("=")
        if not sep or not values:
            raise SystemExit(f"--where {pair!r}: give KEY=VALUE[,VALUE...]")
        parsed[key] = values.split(",")
    return parsed


def folder_runs(results: Path, synthcal: str) -> pd.DataFrame:
    """The runs archive of a whole results folder, as the CLI prints it (its error, one line, when it cannot)."""
    printed = subprocess.run([synthcal, "table", str(results), "--layout", "runs", "--format", "csv"],
                             capture_output=True, text=True)
    if printed.returncode != 0:
        reason = (printed.stderr.strip().splitlines() or [f"exit status {printed.returncode}"])[-1]
        raise SystemExit(f"{results}: `{synthcal} table` printed no runs archive: {reason}")
    return pd.read_csv(io.StringIO(printed.stdout), dtype=str, keep_default_na=False)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("results", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--where", nargs="+", default=[], metavar="KEY=V1,V2")
    parser.add_argument("--expect", type=int, required=True, help="how many runs the slice must hold")
    parser.add_argument("--synthcal", default="synthcal")
    args = parser.parse_args()

    runs = folder_runs(args.results, args.synthcal)
    for key, values in conditions(args.where).items():
        if key not in runs.columns:
            raise SystemExit(f"--where {key}: no such column in the runs archive of {args.results}")
        runs = runs[runs[key].isin(values)]
    runs = runs[runs["status"] == "ok"]
    if len(runs) != args.expect:
        raise SystemExit(f"{args.results}: {len(runs)} finished runs match, not {args.expect}; nothing written")
    if args.out.exists():
        kept = pd.read_csv(args.out, dtype=str, keep_default_na=False)
        if list(kept.columns) != list(runs.columns):
            raise SystemExit(f"{args.out}: its columns differ from the folder's archive; write a new archive")
        runs = pd.concat([kept, runs[~runs["run_id"].isin(kept["run_id"])]], ignore_index=True)
    temporary = args.out.with_name(f".{args.out.name}.tmp")
    runs.to_csv(temporary, index=False)
    os.replace(temporary, args.out)
    print(f"{args.out}: {len(runs)} runs")


if __name__ == "__main__":
    main()
