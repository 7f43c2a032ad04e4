"""Print the README's result tables from a rerun, so that the README matches what the code gives.

Reruns every packaged scenario (``configs/scenarios/``, ``evmap run``) and the rule
comparison (``evmap compare --worlds 200 --seed 1``), each under the paper's config and
the default one (``--configs``), and prints the Markdown
tables of the README's "Other scenarios" and "Rules and configs on 30 generated worlds"
sections, the latter with its paired differences from the first config and
rule. The comparison's numbers do not depend on the scheduler (rows are
gathered in world order), only its timings do.

    .venv/bin/python benchmarks/readme_tables.py [--worlds 200] [--seed 1] [--scheduler ADDRESS]
"""

from __future__ import annotations

import argparse
from importlib.resources import files

from evmap.maps.app.compare_args import DEFAULT_RULES
from evmap.maps.app.compare_runner import run_comparison
from evmap.maps.app.compare_tables import Comparison, markdown_table
from evmap.maps.app.run import report, run_scenario
from evmap.sources.config import load_config
from evmap.sources.sim.scenario import load_scenario

SCENARIOS = {
    "corridor": "corridor",
    "office": "office: rooms, doors, a glass partition",
    "hall": "hall: four pillars, a mirror wall",
    "lab": "lab: a foam (absorbing) screen, glass",
    "patrol": "patrol: a corridor from three poses",
}
"""Scenario file stem -> its row label in the README."""

RULE_COLUMNS = {
    "noise_recall": ("noise recall", "{:.3f}"),
    "real_loss": ("real loss", "{:.3f}"),
    "glass_explained": ("glass explained", "{:.3f}"),
    "mean_conflict": ("mean conflict", "{:.3f}"),
    "map_error": ("map error (m)", "{:.3f}"),
    "spurious_unidentified": ("spurious unidentified", "{:.3f}"),
    "free_behind_walls": ("free cells behind walls", "{:.3f}"),
    "free_behind_opaque": ("free cells behind opaque walls", "{:.4f}"),
    "free_seen_kept": ("seen free kept", "{:.3f}"),
    "noise_recall_pooled": ("noise recall, pooled", "{:.3f}"),
    "real_loss_pooled": ("real loss, pooled", "{:.3f}"),
    "lines": ("lines", "{:.1f}"),
    "unidentified": ("unidentified", "{:.2f}"),
    "seconds_per_world": ("s per world", "{:.3f}"),
}
"""summary.csv column -> the README's heading and format."""


def scenario_table(configs: list[str]) -> str:
    """The "Other scenarios" table: one row per packaged scenario and config (``paper``, ``default``, a path)."""
    out = [
        (
            "| scenario | config | poses | phantoms eliminated | real eliminated | lines before → after | corners "
            "| RCDs actual / simulated / matched | unidentified | s |"
        ),
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for stem, label in SCENARIOS.items():
        scenario = load_scenario(str(files("evmap.configs") / "scenarios" / f"{stem}.yaml"))
        for name in configs:
            r = report(run_scenario(scenario, load_config(name)))
            real = r["lsl_segments"] - r["noise_segments"]
            out.append(
                f"| {label} | {name} | {r['poses']} | {r['noise_eliminated']}/{r['noise_segments']} | "
                f"{r['real_eliminated']}/{real} | {r['lines_before_merge']} → {r['lines_after_merge']} | "
                f"{r['corners']} | {r['rcds_actual']} / {r['rcds_simulated']} / {r['rcds_matched']} | "
                f"{r['unidentified']} | {r['seconds']['total']:.2f} |"
            )
    return "\n".join(out)


def rule_table(comparison: Comparison) -> str:
    """The "Rules on generated worlds" table: the means of summary.csv (with their 95 % intervals for the
    noise recall and the real loss) and the pooled ratios, one row per config and rule."""
    out = [
        "| config | rule | " + " | ".join(h for h, _ in RULE_COLUMNS.values()) + " |",
        "| --- | --- | " + " | ".join("---:" for _ in RULE_COLUMNS) + " |",
    ]
    for row in comparison.summary:
        cells = []
        for c, (_, fmt) in RULE_COLUMNS.items():
            cell = "" if row[c] is None else fmt.format(row[c])
            if c in ("noise_recall", "real_loss") and row.get(f"{c}_lo") is not None:
                cell += f" ({fmt.format(row[f'{c}_lo'])}–{fmt.format(row[f'{c}_hi'])})"
            cells.append(cell)
        out.append(f"| {row['config']} | {row['rule']} | " + " | ".join(cells) + " |")
    return "\n".join(out)


DIFFERENCE_COLUMNS = ("noise_recall", "real_loss", "glass_explained", "spurious_unidentified", "free_behind_walls")
"""The paired differences the README shows."""


def difference_table(comparison: Comparison) -> str:
    """The paired differences from the first config and rule (``summary.md``'s), for :data:`DIFFERENCE_COLUMNS`."""
    return markdown_table(comparison.differences, DIFFERENCE_COLUMNS, dict.fromkeys(DIFFERENCE_COLUMNS, "+.3f"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--worlds", type=int, default=200)
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--scheduler", help="as evmap compare's (default: a local cluster)")
    parser.add_argument("--configs", default="paper,default", help="comma-separated configs (default: %(default)s)")
    parser.add_argument("--rules", default=",".join(DEFAULT_RULES), help="comma-separated rules (default: %(default)s)")
    args = parser.parse_args()
    configs = args.configs.split(",")
    print("### Other scenarios\n")
    print(scenario_table(configs))
    comparison = run_comparison(
        args.rules.split(","), args.worlds, args.seed, scheduler=args.scheduler, progress=True, configs=configs
    )
    print(
        f"\n### Rules on {args.worlds} generated worlds (`evmap compare ... --worlds {args.worlds} --seed {args.seed}`)\n"
    )
    print(rule_table(comparison))
    base = comparison.variants[0]
    print(f"\nPaired differences from {base[0]} / {base[1]} on the same worlds:\n")
    print(difference_table(comparison))


if __name__ == "__main__":
    main()
