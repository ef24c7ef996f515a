"""`pico-gym compare`: its files have the documented fields, and the same seed gives the same numbers."""

import csv
import json

import pytest
from helpers import EPISODE_FIELDS, SUMMARY_FIELDS

from pico_gym.agents.cli import add_compare
from pico_gym.agents.compare import Episodes
from pico_gym.cli import main
from pico_gym.registry import SuiteGroup, task_info


def _run(out, *extra):
    argv = [
        "compare",
        "--agents",
        "classic,wall-follow,random",
        "--episodes",
        "2",
        "--seed",
        "1000",
        "--trajectories",
        "1",
        "--workers",
        "1",
        "--quiet",
        "--out",
        str(out),
        *extra,
    ]
    assert main(argv) == 0


def _numbers(payload):
    """Everything but the measured compute time, which is a timing, not a result."""
    episodes = [{k: v for k, v in e.items() if k != "act_ms"} for e in payload["episodes"]]
    summary = {a: {k: v for k, v in s.items() if k != "act_ms_median"} for a, s in payload["summary"].items()}
    return episodes, summary


@pytest.mark.slow
def test_compare_writes_table_json_csv_and_plots_deterministically(tmp_path, capsys):
    _run(tmp_path / "a")
    printed = capsys.readouterr().out
    assert "| agent | episodes | success | bumps |" in printed and "| classic | 2 |" in printed
    out = tmp_path / "a"
    for name in (
        "results.md",
        "results.json",
        "results.csv",
        "success_times.png",
        "success_bumps.png",
        "trajectories.png",
    ):
        assert (out / name).is_file() and (out / name).stat().st_size > 0, name
    md = (out / "results.md").read_text()
    for column in (
        "success",
        "bumps",
        "idle",
        "timeout",
        "time median",
        "time p90",
        "SPL",
        "SCT median",
        "mean min clearance",
        "compute per step",
    ):
        assert column in md
    payload = json.loads((out / "results.json").read_text())
    assert set(payload["summary"]) == {"classic", "wall-follow", "random"}
    for s in payload["summary"].values():
        assert SUMMARY_FIELDS | {"min_clearance_mean", "act_ms_median"} <= set(s)
    assert len(payload["episodes"]) == 6
    fields = EPISODE_FIELDS | {"agent", "act_ms"}
    assert all(fields <= set(e) for e in payload["episodes"])
    # Every agent faced the same episodes.
    by_agent = {
        a: [(e["map"], e["seed"], e["shortest_path_length"]) for e in payload["episodes"] if e["agent"] == a]
        for a in payload["summary"]
    }
    assert by_agent["classic"] == by_agent["random"] == by_agent["wall-follow"]
    rows = list(csv.DictReader((out / "results.csv").open()))
    assert len(rows) == 6 and fields | {"spl", "sct"} <= set(rows[0])

    _run(tmp_path / "b")
    again = json.loads((tmp_path / "b" / "results.json").read_text())
    assert _numbers(again) == _numbers(payload)


def test_suites():
    assert Episodes.suite("generated", 3, 10).groups == ((SuiteGroup("generated"), (10, 11, 12)),)
    escape_maps = task_info("PicoEscape-v0").shipped_maps()
    maps = Episodes.suite("maps", 2, 0)
    assert [g.label for g, _ in maps.groups] == escape_maps and "escape_2019" in escape_maps
    assert all(name.startswith("escape") for name in escape_maps)
    group = next(g for g, _ in maps.groups if g.label == "escape_2019")
    assert maps.env_kwargs(group) == {"map": "escape_2019", "sample_start": True}
    assert len(Episodes.suite("all", 1, 0).groups) == 1 + len(escape_maps)
    with pytest.raises(
        ValueError, match="PicoEscape-v0 has no suite 'nope'; its suites: generated, cluttered, narrow, maps, all"
    ):
        Episodes.suite("nope", 1, 0)


def test_unknown_agent_is_named(capsys):
    assert main(["compare", "--agents", "classic,genius", "--quiet"]) == 2
    assert "genius" in capsys.readouterr().err
    assert callable(add_compare)


@pytest.mark.slow
def test_the_hospital_suite_holds_the_issue_settings_and_tables_each_group(tmp_path) -> None:  # type: ignore[no-untyped-def]
    from pico_gym.agents.compare import compare

    episodes = Episodes.suite("hospital", 1, 3, env_id="PicoHospital-v0")
    assert [g.label for g, _ in episodes.groups] == ["generated", "hospital_2019 busy", "hospital_2021"]
    busy = episodes.groups[1][0]
    assert episodes.env_kwargs(busy) == {"map": "hospital_2019", "n_boxes": (2, 2), "n_movers": (1, 1),
                                         "n_closed_doors": (1, 1)}  # fmt: skip
    with pytest.raises(ValueError, match="PicoEscape-v0 has no suite 'hospital'"):
        Episodes.suite("hospital", 1, 3)
    compare(["random"], episodes, tmp_path, workers=1, n_rooms=0)
    text = (tmp_path / "results.md").read_text()
    assert "### hospital_2019 busy" in text and "bumps by kind" in text
    assert (tmp_path / "legs.png").stat().st_size > 0 and (tmp_path / "bumps.png").stat().st_size > 0
    records = json.loads((tmp_path / "results.json").read_text())["episodes"]
    assert all(len(r["bump_xy"]) == r["bumps"] for r in records)  # random bumps: each one placed


def test_an_announcing_comparison_lets_the_floor_baselines_play_silent(tmp_path) -> None:  # type: ignore[no-untyped-def]
    """With arrival="announce" every agent plays the same episodes: wall-follow and random never announce."""
    from pico_gym.agents.compare import compare

    options = {"arrival": "announce", "false_announcement": "terminate", "time_limit_s": 5}
    episodes = Episodes.suite("generated", 1, 3, options, env_id="PicoHospital-v0")
    compare(["random", "wall-follow"], episodes, tmp_path, workers=1, n_rooms=0)
    records = json.loads((tmp_path / "results.json").read_text())["episodes"]
    assert {r["agent"] for r in records} == {"random", "wall-follow"}
    assert all(r["metrics"]["false_announcements"] == 0 for r in records)


def test_hospital_records_time_each_leg() -> None:
    import gymnasium as gym

    from pico_gym.agents import make_agent
    from pico_gym.agents.evaluation import run_episode

    env = gym.make("PicoHospital-v0", map="hospital_2019", n_boxes=(0, 0), n_movers=(0, 0), n_closed_doors=(0, 0))
    record = run_episode(env, make_agent("classic", env), 4, options={"cabinet_order": [0, 1, 3]})
    legs = record.metrics["leg_done_s"]
    assert record.success and len(legs) == 3
    assert legs == sorted(legs) and legs[-1] == record.time_s
