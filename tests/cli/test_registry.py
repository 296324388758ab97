"""The command records: one per command, each reaching its run function and naming only its own arguments."""

import argparse
import inspect

import pytest

from casadi_sins.cli.command import NEVER_INPUTS, Command
from casadi_sins.cli.parser import build_parser
from casadi_sins.cli.registry import COMMANDS


def _subparsers():
    (sub,) = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    return sub.choices


def test_the_parser_has_exactly_the_records_commands_in_their_order():
    assert list(_subparsers()) == [c.name for c in COMMANDS]
    assert len({c.name for c in COMMANDS}) == len(COMMANDS)


@pytest.mark.parametrize("record", COMMANDS, ids=lambda c: c.name)
def test_each_record_reaches_a_run_function_of_one_argument(record):
    run = record.function()
    assert callable(run) and len(inspect.signature(run).parameters) == 1


@pytest.mark.parametrize("record", COMMANDS, ids=lambda c: c.name)
def test_a_records_facts_agree_with_its_arguments(record):
    dests = {a.dest for a in _subparsers()[record.name]._actions}
    assert set(record.not_inputs) <= dests, "a not-input argument the command does not take"
    assert ("out" in dests) == (record.output != "none")
    assert ({"quiet", "no_progress"} <= dests) == record.long


def test_owned_files_follow_the_output_kind(tmp_path):
    records = {c.name: c for c in COMMANDS}
    table = tmp_path / "unit.csv"
    assert records["rough"].owned(table) == [table]
    assert records["import"].owned(tmp_path / "r.toml") == [tmp_path / "r.toml", tmp_path / "r.csv"]
    owned = records["calibrate"].owned(table)
    assert owned[0] == table and tmp_path / "unit.report.json" in owned and len(owned) > 4
    assert records["budget"].owned(tmp_path) == [] and records["validate"].owned(None) == []


def test_the_output_is_never_an_input_and_a_record_refuses_an_unknown_kind():
    assert all(not c.is_input(name) for c in COMMANDS for name in NEVER_INPUTS)
    with pytest.raises(ValueError, match="output"):
        Command("x", "x", lambda p: None, ".commands:cmd_rough", output="table")
