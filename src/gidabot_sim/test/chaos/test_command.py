"""`gidabot chaos`: its arguments, defaults and place in bin/gidabot."""

from __future__ import annotations

import pytest

from gidabot_sim.chaos.command import DEFAULT_SEED, parse_args


def test_arguments_and_defaults() -> None:
    args = parse_args([])
    assert args.seed == DEFAULT_SEED and args.profile == "full" and args.tour.name == "long_tour.tour"
    assert args.speed is None and not args.json
    args = parse_args(["--seed", "7", "--profile", "quick", "--json", "--speed", "5"])
    assert (args.seed, args.profile, args.json, args.speed) == (7, "quick", True, 5.0)
    with pytest.raises(SystemExit):
        parse_args(["--profile", "nope"])


def test_cli_knows_chaos() -> None:
    from gidabot_sim.cli import COMMANDS

    assert COMMANDS["chaos"][0] == "gidabot_sim.chaos.command"
