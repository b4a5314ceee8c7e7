"""The runs archives kept in git (docs/results/runs_*.csv) against the report that quotes them.

The sweep folders do not outlive a session; these archives are what is left of the runs. Two things must hold
for the report to stay honest: today's code still reads every archive, and every verdict docs/reproduction.md
prints for an archived cell is the one the archive gives — the same interval, to the printed digit, followed
by the same verdict in a verdict table; so must the paired comparisons of two losses and of the two trainings it
quotes from them (``--paired loss=A loss=B``, ``--paired training=end-to-end training=step-by-step``, across two
archives with ``--against``).
"""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from collections.abc import Sequence
from functools import cache
from pathlib import Path

import pandas as pd
import pytest
from scipy import stats
from sweep_scripts import REPORT, ROOT, report_section, sweep_script, table_rows

import synthcal
from synthcal.eval.archive import read_archive
from synthcal.eval.statistics import UNDECIDED, VERDICTS

ARCHIVES = sorted((ROOT / "docs" / "results").glob("runs_*.csv"))


def _signed(value: float) -> str:
    """``+2.34`` / ``−3.05`` as reproduction.md prints a difference (a true minus sign)."""
    return f"{value:+.2f}".replace("-", "\u2212")


def _interval(difference: float, low: float, high: float) -> str:
    """``−4.43 [−8.80, −0.06]``: a difference and its 95 % interval as reproduction.md prints them."""
    return f"{_signed(difference)} [{_signed(low)}, {_signed(high)}]"


def _quoted_with_verdict(interval: str, verdict: str, text: str) -> bool:
    """Whether a verdict table of ``text`` has ``interval`` in one cell and ``verdict`` in the next (the
    undecided verdict in its short form)."""
    forms = {verdict, verdict.replace(UNDECIDED, "consistent (and with no difference)")}
    return any(f"{interval} | {form} |" in text for form in forms)


def test_there_are_archives_to_check():
    assert ARCHIVES, "docs/results holds no runs archive"


@pytest.mark.parametrize("archive", ARCHIVES, ids=lambda path: path.name)
@pytest.mark.parametrize("metric", ["iou", "iou_weighted"])
def test_every_judged_cell_of_an_archive_is_quoted_with_its_verdict(archive: Path, metric: str):
    cells = synthcal.report(archive, metric=metric)
    judged = cells[cells["verdict"].isin([*VERDICTS, UNDECIDED])]
    text = REPORT.read_text(encoding="utf-8")
    for cell in judged.itertuples():
        interval = _interval(cell.difference, cell.t_low, cell.t_high)
        assert interval in text, f"{archive.name}: {cell.dataset} {cell.training} {cell.loss} {metric}: {interval} not in {REPORT.name}"
        assert _quoted_with_verdict(interval, cell.verdict, text), (
            f"{archive.name}: {cell.dataset} {cell.loss} {metric}: {interval} is not followed by '{cell.verdict}'"
        )


@pytest.mark.parametrize("metric", ["iou", "iou_weighted"])
@pytest.mark.parametrize(("archive", "dataset", "training", "loss", "model", "matching"), [
    ("runs_tenth.csv", "intersection-1", "step-by-step", "top-mse", "sha2020", "top-mse"),
    ("runs_thirteenth.csv", "intersection-2", "step-by-step", "top-mse", "sha2020", "top-mse"),
    ("runs_seventeenth.csv", "intersection-1", "end-to-end", "top-mse", "sha2020", "top-mse"),
    ("runs_eighteenth.csv", "intersection-1", "step-by-step", "top-dice", "sha2020", "top-mse"),
    ("runs_thirtyfourth.csv", "intersection-3", "step-by-step", "top-mse", "sha2020", "top-mse"),
    ("runs_thirtyfifth.csv", "intersection-4", "step-by-step", "top-mse", "sha2020", "top-mse"),
    ("runs_thirtyfifth.csv", "intersection-5", "step-by-step", "top-mse", "sha2020", "top-mse"),
    ("runs_fiftythird.csv", "intersection-1", "step-by-step", "top-mse", "proposed", "top-mse"),
    ("runs_fiftythird.csv", "intersection-1", "step-by-step", "top-mse", "proposed", "mse"),
    ("runs_fiftythird.csv", "intersection-2", "step-by-step", "top-mse", "proposed", "top-mse"),
    ("runs_fiftythird.csv", "intersection-2", "step-by-step", "top-mse", "proposed", "mse"),
])
def test_the_rerun_cell_reproduces_the_lost_folders_figures(metric: str, archive: str, dataset: str, training: str,
                                                             loss: str, model: str, matching: str):
    """The tenth, thirteenth, seventeenth, eighteenth, thirty-fourth and thirty-fifth sessions reran `sha2020` (true
    maps) on another machine and code hash, the fifty-third the proposed model on intersections 1 and 2 under both
    matchings; reproduction.md ("The same cell again", "The cell again, with sha2020-ccbv", "The cell again" under
    intersection-1's end-to-end training and under its Top-Dice loss, "Intersection-3 again, with sha2020-ccbv",
    "Intersection-4 again", "Intersection-5 again", "Both rows again") says every figure equals the lost folder's
    report to the last printed digit (to 12 significant digits here)."""
    keys = {"dataset": dataset, "training": training, "loss": loss, "model": model, "matching_score": matching,
            "segmentation": "ground-truth", "dictionary": "split"}
    printed = pd.read_csv(ROOT / "docs" / "results" / f"report_{metric}.csv")
    rerun = synthcal.report(ROOT / "docs" / "results" / archive, metric=metric)
    first, again = (frame.loc[(frame[list(keys)] == pd.Series(keys)).all(axis=1)] for frame in (printed, rerun))
    assert len(first) == len(again) == 1
    for column in ("n_seeds", "learning_rates", "stn_epochs", "paper"):
        assert first[column].iloc[0] == again[column].iloc[0], column
    for column in ("mean", "std"):  # the same per-image scores: only the order of a sum may move the 16th digit
        assert first[column].iloc[0] == pytest.approx(again[column].iloc[0], rel=1e-12, abs=0), column


# The paired comparisons of two losses reproduction.md quotes from the archives ("The topological loss against
# its conventional version"): side A's archive, side B's (None: the same one), the two losses.
LOSS_PAIRS = [
    ("runs_fourteenth.csv", None, "top-mse", "mse"),
    ("runs_fifteenth.csv", None, "top-mse", "mse"),
    ("runs_eleventh.csv", None, "top-dice", "dice"),
    ("runs_tenth.csv", "runs_sixteenth.csv", "top-mse", "mse"),
    ("runs_seventeenth.csv", "runs_sixteenth.csv", "top-mse", "mse"),
    ("runs_seventeenth.csv", "runs_sixteenth.csv", "top-dice", "dice"),
    ("runs_eighteenth.csv", "runs_tenth.csv", "top-dice", "dice"),
    ("runs_twentieth.csv", "runs_eighteenth.csv", "top-dice", "dice"),
    ("runs_twentyfirst.csv", None, "top-dice", "dice"),
    ("runs_twentyfirst_gpu.csv", None, "top-dice", "dice"),
    ("runs_fiftysecond.csv", None, "top-dice", "dice"),
    ("runs_fiftyeighth.csv", None, "top-dice", "dice"),
    ("runs_twentysecond.csv", None, "top-dice", "dice"),
    ("runs_twentysecond.csv", None, "top-mse", "mse"),
    ("runs_twentyninth.csv", None, "top-dice", "dice"),
    ("runs_twentyninth.csv", None, "top-mse", "mse"),
    ("runs_thirtysecond.csv", None, "top-dice", "dice"),
    ("runs_thirtythird.csv", None, "top-mse", "mse"),
    ("runs_thirtythird.csv", "runs_thirtyfourth.csv", "top-mse", "mse"),
]


# The paired comparisons of the two trainings reproduction.md quotes ("End to end against step by step"): the
# end-to-end runs' archive, the step-by-step runs' (None: the same one), kept in the script that prints the table.
# Pairs across archives whose runs differ in what no key shows (the fits ranked by another validation score:
# runs_twentyfourth_iou.csv, runs_twentythird_iou.csv) are left out: the report does not quote them.
PAIRED_TABLES = sweep_script("paired_table")
TRAINING_PAIRS = PAIRED_TABLES.TABLES["training"].pairs
QUOTED_PAIRS = [
    *[(archive, against, f"loss={a}", f"loss={b}") for archive, against, a, b in LOSS_PAIRS],
    *[(archive, against, "training=end-to-end", "training=step-by-step") for archive, against in TRAINING_PAIRS],
]


_CELL_KEYS = [key for key in PAIRED_TABLES.CELL_KEYS if key != "training"]  # the keys a superseded cell shares


@cache
def _training_cells(archive: str, against: str | None) -> frozenset[tuple[str, ...]]:
    """The cells (paired_table.py's cell keys but the training) one pair of the training table can pair: end to end
    in ``archive``, step by step in ``against`` (or the same archive). Read from the archives' rows, not paired, so
    the check stays as cheap as the quoting it guards."""

    def cells(name: str, training: str) -> set[tuple[str, ...]]:
        runs = read_archive(ROOT / "docs" / "results" / name)
        return set(runs.loc[runs["training"] == training, _CELL_KEYS].itertuples(index=False, name=None))

    return frozenset(cells(archive, "end-to-end") & cells(against or archive, "step-by-step"))


def _superseded(archive: str, against: str | None, cell: pd.Series) -> bool:
    """Whether a later pair of the training table gives the same cell (paired_table.py prints that pair's)."""
    if (archive, against) not in TRAINING_PAIRS:
        return False
    later = TRAINING_PAIRS[TRAINING_PAIRS.index((archive, against)) + 1:]
    key = tuple(cell[_CELL_KEYS])
    return any(key in _training_cells(*pair) for pair in later)


@pytest.mark.parametrize("metric", ["iou", "iou_weighted"])
@pytest.mark.parametrize(("archive", "against", "a", "b"), QUOTED_PAIRS)
def test_every_judged_pair_of_the_archives_is_quoted_with_its_verdict(
    metric: str, archive: str, against: str | None, a: str, b: str
):
    results = ROOT / "docs" / "results"
    cells = synthcal.paired_differences(results / archive, a, b, metric=metric,
                                        against=None if against is None else results / against)
    judged = cells[cells["verdict"].isin([*VERDICTS, UNDECIDED])]
    assert not judged.empty, f"{archive}: no judged {a} − {b} cell"
    judged = judged[~judged.apply(lambda cell: _superseded(archive, against, cell), axis=1)]
    text = REPORT.read_text(encoding="utf-8")
    for cell in judged.itertuples():
        interval = _interval(cell.mean, cell.t_low, cell.t_high)
        assert _quoted_with_verdict(interval, cell.verdict, text), (
            f"{archive}: {cell.dataset} {cell.model} {cell.loss} {a} − {b} {metric}: '{interval} | {cell.verdict} |' "
            f"not in {REPORT.name}"
        )


def test_the_verdict_tally_counts_the_verdict_table():
    """reproduction.md's "Tally of the N cells" sentence against its "Verdicts so far" table, the UNet cell
    counted once (its class-weighted reading; the plain-loss and 10-epoch variants are extra rows)."""
    text = REPORT.read_text(encoding="utf-8")
    section = text.split("## Verdicts so far", 1)[1].split("\nTally of the ", 1)
    rows = [line for line in section[0].splitlines() if line.startswith("| ") and not line.startswith("| cell")]
    rows = [row for row in rows if "the paper's plain loss" not in row and "10-epoch" not in row]

    def count(column: int) -> dict[str, int]:
        verdicts = [row.strip("| ").split(" | ")[column].split(" (")[0].replace("consistent with the paper", "consistent")
                    for row in rows]
        return {v: verdicts.count(v) for v in ("opposite", "not reproduced", "consistent")}

    tally = " ".join(section[1].split("\n\n", 1)[0].split())
    assert tally.startswith(f"{len(rows)} cells")
    for reading, column in (("`iou_weighted`", 5), ("`iou`", 3)):
        n = count(column)
        said = f"under {reading} {n['opposite']} opposite, {n['not reproduced']} not reproduced, {n['consistent']} consistent"
        assert said in tally, f"{REPORT.name}: the tally does not say '{said}'"


UNET_TABLE = sweep_script("unet_table")


@pytest.mark.parametrize(("dataset", "loss"), list(UNET_TABLE.CELLS))
def test_each_unet_cells_table_is_what_its_script_prints(dataset: str, loss: str):
    """A "The UNet in the loop" section's per-seed table (UNet maps beside true maps) is docs/sweeps/unet_table.py's
    output today, from the two archives the script names for the cell."""
    section = UNET_TABLE.CELLS[(dataset, loss)].section
    assert "\n".join(UNET_TABLE.lines(dataset, loss)) in report_section(section), (
        f"{REPORT.name}, {section}: not the table `unet_table.py {dataset} {loss}` prints")


@pytest.mark.parametrize("metric", ["iou", "iou_weighted"])
@pytest.mark.parametrize(("dataset", "loss"), list(UNET_TABLE.CELLS))
def test_each_unet_cells_difference_of_costs_is_what_table_between_prints(metric: str, dataset: str, loss: str):
    """The difference of the two models' UNet costs ((true maps − UNet maps) of the proposed model minus the same of
    sha2020, paired over seeds) a UNet section quotes is `synthcal table TRUE --against UNET --paired
    segmentation=ground-truth segmentation=unet --between proposed sha2020` today, to the printed digit."""
    cell = UNET_TABLE.CELLS[(dataset, loss)]
    results = ROOT / "docs" / "results"
    cells = synthcal.paired_contrast(results / cell.true_maps, "segmentation=ground-truth", "segmentation=unet",
                                     "proposed", "sha2020", metric=metric, against=results / cell.unet_maps)
    cells = cells[(cells["dataset"] == dataset) & (cells["loss"] == loss)]
    seeds = len(UNET_TABLE.readings(cell.unet_maps, dataset, loss, "unet", "iou"))
    assert len(cells) == 1 and cells["n_pairs"].iloc[0] == seeds
    quoted = _interval(cells["mean"].iloc[0], cells["t_low"].iloc[0], cells["t_high"].iloc[0])
    assert quoted in " ".join(report_section(cell.section).split()), (
        f"{REPORT.name}, {cell.section}: {metric} {quoted} not quoted")


def _number(text: str) -> float:
    return float(text.replace("\u2212", "-"))


@pytest.mark.parametrize(("name", "section"), [("training", "## End to end against step by step"),
                                             ("matching", "## The matching score"),
                                             ("top-mse-loss", "## The topological loss against"),
                                             ("top-dice-loss", "## The topological loss against")])
def test_each_paired_table_is_what_its_script_prints(name: str, section: str):
    """reproduction.md's tables of end to end − step by step, of Top-MSE − MSE matching and of each topological loss
    against its conventional version under MSE matching are docs/sweeps/paired_table.py's output today: a pair added
    to the script, an archive rewritten or a verdict rule changed without reprinting the table fails here; and no cell
    is printed twice (two pairs giving it: the later one's is kept)."""
    lines = PAIRED_TABLES.lines(name)
    assert len(lines) > 2, f"paired_table.py {name} printed no rows"
    assert "\n".join(lines) in report_section(section), f"{REPORT.name}, {section}: not the table `paired_table.py {name}` prints"
    labels = [row[0] for row in table_rows("\n".join(lines))]
    assert len(set(labels)) == len(labels), f"paired_table.py {name}: a cell printed twice, from two pairs"


SELECTION_TABLE = sweep_script("selection_table")


def test_the_selection_table_is_what_its_script_prints():
    """reproduction.md's summary of the selection score (proposed − sha2020 ranked by `L_warp` and by `iou`, and the
    shift) is docs/sweeps/selection_table.py's output today, its closing sentence over the cells included."""
    lines = SELECTION_TABLE.lines()
    assert len(lines) > 4, "selection_table.py printed no rows"
    section = report_section("## Does the selection score decide a verdict?")
    assert "\n".join(lines[:-2]) in section, f"{REPORT.name}: not the table `selection_table.py` prints"
    assert " ".join(lines[-1].split()) in " ".join(section.split()), f"{REPORT.name}: not the sentence it prints"


def test_the_selection_table_refuses_a_cell_without_both_models_on_every_seed():
    """A cell the archive lacks, or holds for one model only, is named in an error instead of read as a gap."""
    with pytest.raises(ValueError, match=r"runs_twentyfourth_iou\.csv: intersection-5 dice"):
        SELECTION_TABLE.gaps("runs_twentyfourth_iou.csv", "intersection-5", "dice", "iou")


def test_the_selection_table_gap_is_the_paired_report_difference():
    """The script's per-seed gap, averaged, is the difference `synthcal table --layout report` prints for the cell
    (computed there by another path: the report's pairing of each run with sha2020's on its seed)."""
    dataset, loss, _, archive = SELECTION_TABLE.CELLS[0]
    report = synthcal.report(ROOT / "docs" / "results" / archive, metric="iou")
    cell = report[(report["dataset"] == dataset) & (report["loss"] == loss) & (report["model"] == "proposed")
                  & (report["training"] == "step-by-step")]
    assert len(cell) == 1
    gap = SELECTION_TABLE.gaps(archive, dataset, loss, "iou")
    assert gap.mean() == pytest.approx(cell["difference"].iloc[0], abs=1e-9)


def _reading(cell: str) -> tuple[float, float, float]:
    """``−0.81 [−1.25, −0.37]`` → the difference and its interval's bounds."""
    mean, bounds = cell.split(" [")
    low, high = bounds.rstrip("]").split(", ")
    return _number(mean), _number(low), _number(high)


_WORDS = ["none", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine", "ten"]


def test_the_mse_matching_loss_counts_count_its_tables():
    """reproduction.md's counts of the topological loss under MSE matching ("Under MSE matching": cells, above by an
    interval that excludes 0, below on the mean, below by such an interval), and the count In brief and "Verdicts so
    far" repeat, against the rows of its two tables."""
    section = report_section("## The topological loss against")
    tables = {name: table_rows("\n".join(PAIRED_TABLES.lines(name))) for name in ("top-mse-loss", "top-dice-loss")}
    rows = [row for cells in tables.values() for row in cells]
    prose = " ".join(section.split())
    readings = {metric: [_reading(row[column]) for row in rows] for metric, column in (("iou", 3), ("iou_weighted", 5))}
    above = sum(any(readings[metric][i][1] > 0 for metric in readings) for i in range(len(rows)))  # either reading
    assert above < len(_WORDS), f"{above} cells above: name the number in words here as the prose does"
    assert f"Of these {len(rows)} cells the topological loss is above its conventional version by an interval that " \
           f"excludes 0 in {_WORDS[above]}, under either reading" in prose
    below = {metric: sum(high < 0 for _, _, high in readings[metric]) for metric in readings}
    assert f"its mean is below in {sum(mean < 0 for mean, _, _ in readings['iou'])} under `iou`" in prose
    assert f"below by an interval that excludes 0 in {below['iou']} (`iou_weighted`: {below['iou_weighted']})" in prose
    for name, pair in (("top-dice-loss", "Top-Dice − Dice averages"), ("top-mse-loss", "Top-MSE − MSE")):
        cells = tables[name]
        mean = _signed(sum(_reading(row[3])[0] for row in cells) / len(cells))
        paper = _signed(sum(_number(row[2]) for row in cells) / len(cells))
        assert f"{pair} {mean} `iou` over its {len(cells)}" in prose and f"(the paper {paper})" in prose, name
    # the two summaries repeat the count of cells and of those above
    brief = " ".join(report_section("## In brief").split())
    assert f"under MSE matching {_WORDS[above]} of {len(rows)} cells above" in brief, "In brief counts other cells"
    verdicts = " ".join(report_section("## Verdicts so far").split())
    assert f"where {_WORDS[above]} of the proposed model's {len(rows)} archived cells is above" in verdicts, \
        "Verdicts so far counts other cells"


def test_the_end_to_end_counts_count_the_end_to_end_table():
    """reproduction.md's "End to end against step by step" counts of the proposed model's cells — above by an
    interval that excludes 0, below on the mean, below by such an interval, the verdicts where the paper has end to end
    above — against the rows of its table (`iou`: the cell, archives, paper, interval, verdict, ...)."""
    section = report_section("## End to end against step by step")
    rows = table_rows(section)
    proposed = [row for row in rows if row[0].endswith(", proposed")]
    means, lows, highs = zip(*(_reading(row[3]) for row in proposed), strict=True)
    above = sum(low > 0 for low in lows)
    prose = " ".join(section.split())
    assert above < len(_WORDS), f"{above} cells above: name the number in words here as the prose does"
    opening = "In none" if above == 0 else f"Only in {_WORDS[above]}"
    assert f"{opening} of the proposed model's {len(proposed)} paired cells" in prose
    assert f"its mean is below in {sum(mean < 0 for mean in means)}," in prose
    assert f"excludes 0 in {sum(high < 0 for high in highs)} under `iou`" in prose
    lifted = [row for row in proposed if _number(row[2]) > 0]  # the paper's end to end above its step by step
    verdicts = [Counter(row[column] for row in lifted) for column in (4, 6)]  # iou, iou_weighted
    counts = [(tally["opposite"], tally["not reproduced"], tally["consistent (and with no difference)"])
              for tally in verdicts]
    assert all(sum(count) == len(lifted) for count in counts), f"a verdict the prose does not count: {verdicts}"
    assert f"Of the {len(lifted)} cells where the paper has end to end lifting its model, ours are opposite in " \
           f"{counts[0][0]}, not reproduced in {counts[0][1]} and hold both 0 and the paper's figure in {counts[0][2]} " \
           f"under `iou` ({counts[1][0]}, {counts[1][1]} and {counts[1][2]} under `iou_weighted`)" in prose
    brief = " ".join(report_section("## In brief").split())
    assert f"of its {len(proposed)} cells paired by seed" in brief, "In brief counts another number of cells"
    assert f"below by one in {sum(high < 0 for high in highs)};" in brief, "In brief counts another number below"


def test_the_budget_table_is_the_archives_seconds():
    """reproduction.md's table of seconds per archived run is what docs/sweeps/run_seconds.py prints from the
    archives today: an archive added or changed without rerunning the script fails here."""
    script = ROOT / "docs" / "sweeps" / "run_seconds.py"
    printed = subprocess.run([sys.executable, str(script)], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    table = [line for line in printed.splitlines() if line.startswith("|")]
    assert len(table) > 2, "run_seconds.py printed no rows"
    assert "\n".join(table) in REPORT.read_text(encoding="utf-8")


def test_the_matching_summary_sums_up_the_matching_table():
    """The sentence under "Every archived pair." — how many cells, their mean `iou` difference against the paper's,
    how many are above 0 and how many by an interval that excludes 0, the t interval of the average over the cells
    and over the datasets' averages — against that table's rows (scipy's interval, not synthcal's)."""
    section = report_section("## The matching score")
    table = section.split("| cell | archives, Top-MSE − MSE matching |", 1)[1].split("\n\n", 1)
    rows = table_rows(table[0])
    means, lows, highs = zip(*(_reading(row[3]) for row in rows), strict=True)
    papers = [_number(row[2]) for row in rows]
    excluding = sum(low > 0 or high < 0 for low, high in zip(lows, highs, strict=True))
    summary = (f"Over its {len(rows)} cells the mean `iou` difference is {_signed(sum(means) / len(means))}, against "
               f"the paper's {_signed(sum(papers) / len(papers))} over the same cells: {sum(m > 0 for m in means)} are "
               f"above 0, {_WORDS[excluding]} by an interval that excludes 0 under `iou`.")
    prose = " ".join(table[1].split())
    assert summary in prose, f"not under the table: {summary}"
    datasets = pd.Series(means).groupby([row[0].split(",")[0] for row in rows]).mean()
    averages = (f"A t interval over the {len(rows)} cells puts the average at {_mean_interval(means)}; averaged "
                f"within each of the {len(datasets)} datasets first (a dataset's cells share its stores and seeds, "
                f"so they are not independent), at {_mean_interval(datasets)}.")
    assert averages in prose, f"not under the table: {averages}"


def _mean_interval(values: Sequence[float] | pd.Series) -> str:
    """``+0.50 [−0.10, +1.10]`` (a made-up example, not a report figure): the mean of ``values`` and its 95 % t
    interval (scipy's, not synthcal's)."""
    values = list(values)
    low, high = stats.ttest_1samp(values, 0.0).confidence_interval(0.95)
    return _interval(sum(values) / len(values), low, high)
