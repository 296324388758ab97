"""Property-based tests of the recording reader (issue 17): a mutated recording ends in a valid result
or one clear error, never in a traceback or a silently different table."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from casadi_sins.cli import main
from casadi_sins.core.errors import InputError
from casadi_sins.data.description import read_recording, write_recording
from casadi_sins.sim import simulate

_spec = importlib.util.spec_from_file_location("mutations", Path(__file__).with_name("mutations.py"))
mutations = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(mutations)


@pytest.fixture(scope="module")
def original(short_problem, tmp_path_factory):
    path = write_recording(simulate(short_problem, seed=6).recording, tmp_path_factory.mktemp("orig") / "r.toml")
    return path.read_text(), path.with_suffix(".csv").read_text()


def read_or_refuse(folder: Path, toml: str, csv: str):
    """The reader's numbers, or ``None`` when it refuses with an :class:`InputError` (any other exception fails)."""
    (folder / "r.toml").write_text(toml)
    (folder / "r.csv").write_text(csv)
    try:
        rec = read_recording(folder / "r.toml")
    except InputError as exc:
        assert "\n" not in str(exc) and len(str(exc)) < 2500
        return None
    return np.column_stack([rec.time, rec.gyro, rec.accel])


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(kind=st.sampled_from(sorted(mutations.CSV_MUTATIONS)), seed=st.integers(0, 10**6))
def test_a_mutated_csv_is_refused_or_read_exactly_as_its_text_says(original, tmp_path, kind, seed):
    toml, csv = original
    mutated = mutations.mutate_csv(csv, kind, seed)
    got = read_or_refuse(tmp_path, toml, mutated)
    expected = mutations.oracle(mutated)
    if expected is None:
        assert got is None, f"{kind}: accepted a CSV that is no valid table of samples"
    elif got is not None:
        np.testing.assert_array_equal(got, expected)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(index=st.integers(0, len(mutations.TOML_EDITS) - 1), seed=st.integers(0, 10**6))
def test_a_mutated_description_gives_a_recording_or_one_line(original, tmp_path, capsys, index, seed):
    toml, csv = original
    (tmp_path / "r.toml").write_text(mutations.mutate_toml(toml, index, seed))
    (tmp_path / "r.csv").write_text(csv)
    status = main(["validate", str(tmp_path / "r.toml")])
    err = capsys.readouterr().err.strip()
    assert status in (0, 2)
    if status == 2:
        assert len(err.splitlines()) == 1 and ("r.toml" in err or "r.csv" in err or "zero" in err), err


def test_every_csv_mutation_class_is_exercised():
    assert len(mutations.CSV_MUTATIONS) >= 14 and len(mutations.TOML_EDITS) >= 15
