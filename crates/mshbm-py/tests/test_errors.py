"""Every bad input of the CLI's bad-input tests (crates/mshbm-cli/tests/bad_input.rs)
raises the right exception, with the CLI's message (`error: MESSAGE` on its stderr), and
never crashes the interpreter."""

from __future__ import annotations

import os
import re
import time
from pathlib import Path

import numpy as np
import pytest

import mshbm
from conftest import BAR, DAMPED_SET, EXAMPLES


def bar_with(tmp_path, old, new):
    text = BAR.read_text()
    assert old in text, f"fixture lacks {old}"
    p = tmp_path / "bar.toml"
    p.write_text(text.replace(old, new))
    return p


def edit(model_dir, old, new):
    p = model_dir / "model.toml"
    text = p.read_text()
    assert old in text, f"fixture lacks {old}"
    p.write_text(text.replace(old, new))


def check(cli, exc_type, load, cli_args, *fragments, fast=False):
    """`load()` raises `exc_type` whose message the CLI prints for `cli_args`, and which
    contains every fragment."""
    start = time.perf_counter()
    with pytest.raises(exc_type) as info:
        load()
    if fast:
        assert time.perf_counter() - start < 1.0
    message = str(info.value)
    for f in fragments:
        assert f in message, f"{f!r} not in {message!r}"
    out = cli(*cli_args, check=False)
    assert out.returncode == 1, out.stderr
    assert f"error: {message}" in out.stderr, f"python: {message!r}\ncli: {out.stderr!r}"
    assert isinstance(info.value, mshbm.MshbmError)
    return message


def test_missing_model_file(cli):
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml("no/such/model.toml"),
          ["modes", "no/such/model.toml"], "no/such/model.toml")


def test_malformed_toml(cli, tmp_path):
    p = bar_with(tmp_path, "[bar]", "[bar")
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(p), ["modes", p], "bar.toml", "malformed TOML")


def test_unknown_key(cli, tmp_path):
    p = bar_with(tmp_path, "area = 1.0", "area = 1.0\nwidth = 3.0")
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(p), ["modes", p], "bar.toml", "width", "bar")


def test_unknown_key_through_set(cli):
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(BAR, {"contact.gapp": 0.1}),
          ["modes", BAR, "--set", "contact.gapp=0.1"], "gapp")


def test_negative_density(cli, tmp_path):
    p = bar_with(tmp_path, "density = 9e-9", "density = -9e-9")
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(p), ["modes", p], "bar.toml", "bar.density", "positive")


def test_non_square_matrix(cli, general_model):
    (general_model / "mass.mtx").write_text("%%MatrixMarket matrix coordinate real general\n3 2 1\n1 1 1.0\n")
    toml = general_model / "model.toml"
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml],
          "model.toml", "matrices.mass", "not square")


def test_non_symmetric_matrix(cli, general_model):
    lines = (EXAMPLES / "bar_matrices/stiffness.mtx").read_text().splitlines()
    entries = []
    for e in lines[2:]:
        entries.append(e)
        i, j, v = e.split()
        if i != j:
            entries.append(f"{j} {i} {v}")
    entries.append("1 3 5.0")
    n = lines[1].split()[0]
    (general_model / "stiffness.mtx").write_text(
        f"%%MatrixMarket matrix coordinate real general\n{n} {n} {len(entries)}\n" + "\n".join(entries) + "\n")
    toml = general_model / "model.toml"
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml],
          "matrices.stiffness", "not symmetric")


def test_size_mismatch_between_matrices_and_coordinates(cli, general_model):
    (general_model / "nodes.txt").write_text("0.0\n0.2\n0.4\n")
    toml = general_model / "model.toml"
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "model.toml", "mesh.coordinates")


def test_size_mismatch_between_matrices(cli, general_model):
    (general_model / "mass.mtx").write_text("%%MatrixMarket matrix coordinate real symmetric\n3 3 1\n1 1 1.0\n")
    toml = general_model / "model.toml"
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "matrices.mass", "3×3")


def test_contact_dof_out_of_range(cli, general_model):
    edit(general_model, "dofs = [100]", "dofs = [101]")
    toml = general_model / "model.toml"
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "contacts[0].dofs", "out of range")


def test_malformed_matrix_market_line(cli, general_model):
    (general_model / "mass.mtx").write_text("%%MatrixMarket matrix coordinate real symmetric\n101 101 1\n1 1 abc\n")
    toml = general_model / "model.toml"
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "mass.mtx, line 3")


def test_count_larger_than_the_number_of_dofs(cli):
    bar = mshbm.Model.from_toml(BAR)
    check(cli, mshbm.MshbmError, lambda: mshbm.modes(bar, 500), ["modes", BAR, "--count", 500], "count", "500")
    with pytest.raises(mshbm.ArgumentError):
        mshbm.modes(bar, 500)


def test_bad_override_syntax(cli):
    check(cli, mshbm.ArgumentError, lambda: mshbm.Model.from_toml(BAR, ["contact.gap"]),
          ["modes", BAR, "--set", "contact.gap"], "key=value")


def test_huge_bar_elements_are_refused_at_once(cli):
    for n in ["4611686018427387904", "1000000000"]:
        check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(BAR, [f"bar.elements={n}"]),
              ["modes", BAR, "--set", f"bar.elements={n}"], "clamped_bar.toml", "bar.elements", "--max-memory", fast=True)
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(BAR, max_memory_gib=0.0001),
          ["modes", BAR, "--max-memory", "0.0001"], "bar.elements", "104.9 KiB", fast=True)
    dropped = EXAMPLES / "dropped_bar.toml"
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(dropped, {"bar.elements": 1000000000}),
          ["simulate", dropped, "--set", "bar.elements=1000000000"], "bar.elements", fast=True)


def test_huge_declared_matrix_market_sizes_are_refused_at_once(cli, general_model):
    toml = general_model / "model.toml"
    for size in ["1000000000 1000000000 1", "4294967296 4294967296 1",
                 "18446744073709551615 18446744073709551615 1", "101 101 18446744073709551615"]:
        (general_model / "stiffness.mtx").write_text(f"%%MatrixMarket matrix coordinate real general\n{size}\n1 1 1.0\n")
        check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "stiffness.mtx", fast=True)


def test_devices_and_fifos_as_referenced_files_are_refused_at_once(cli, general_model):
    toml = general_model / "model.toml"
    edit(general_model, '"stiffness.mtx"', '"/dev/zero"')
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml],
          "matrices.stiffness", "--allow-outside-paths", fast=True)
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml, allow_outside_paths=True),
          ["modes", toml, "--allow-outside-paths"], "matrices.stiffness", "not a regular file", fast=True)
    edit(general_model, '"/dev/zero"', '"stiffness.mtx"')
    os.mkfifo(general_model / "nodes.fifo")
    edit(general_model, '"nodes.txt"', '"nodes.fifo"')
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "mesh.coordinates", "FIFO", fast=True)


def test_paths_outside_the_model_directory_are_refused(cli, general_model):
    toml = general_model / "model.toml"
    edit(general_model, '"nodes.txt"', '"/etc/passwd"')
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml],
          "model.toml", "mesh.coordinates", '"/etc/passwd"', "--allow-outside-paths", fast=True)
    edit(general_model, '"/etc/passwd"', '"../nodes.txt"')
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "mesh.coordinates", "leads outside", fast=True)


def test_escape_sequences_in_bad_tokens_are_escaped(cli, general_model):
    (general_model / "mass.mtx").write_text(
        "%%MatrixMarket matrix coordinate real symmetric\n101 101 1\n1 1 \x1b[31m\x1b]0;pwned\x07\n")
    toml = general_model / "model.toml"
    message = check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml],
                    "mass.mtx, line 3", "\\u{1b}[31m")
    assert "\x1b" not in message and "\x07" not in message


def test_degenerate_contacts_are_refused(cli, general_model, tmp_path):
    toml = general_model / "model.toml"
    original = toml.read_text()
    edit(general_model, "dofs = [100]\nw = [-1.0]", "dofs = [3, 3]\nw = [-1.0, 1.0]")
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "model.toml", "contacts[0].w", "vanishes")
    toml.write_text(original + "\n[[contacts]]\ndofs = [100]\nw = [-1.0]\ngap = 0.2\n")
    check(cli, mshbm.ModelError, lambda: mshbm.Model.from_toml(toml), ["modes", toml], "contacts[1]", "contacts[0]", "singular")


# --- the same checks on models from arrays: ModelError naming `<arrays>` and the field ---

def bar_arrays():
    return mshbm.Model.from_toml(BAR).arrays()


def test_arrays_models_are_validated_by_the_library():
    a = bar_arrays()
    a["contacts"] = [{"dofs": [101], "w": [-1.0], "gap": 0.2}]
    with pytest.raises(mshbm.ModelError, match=r"<arrays>: field `contacts\[0\]\.dofs`.*out of range"):
        mshbm.Model.from_arrays(**a)
    a = bar_arrays()
    a["mass"] = a["mass"][:100, :100]
    with pytest.raises(mshbm.ModelError, match=r"matrices\.mass.*100×100"):
        mshbm.Model.from_arrays(**a)
    a = bar_arrays()
    k = a["stiffness"].tolil()
    k[0, 2] = 5.0
    a["stiffness"] = k
    with pytest.raises(mshbm.ModelError, match="not symmetric"):
        mshbm.Model.from_arrays(**a)
    a = bar_arrays()
    a["coordinates"] = a["coordinates"][:3]
    with pytest.raises(mshbm.ModelError, match="mesh.coordinates"):
        mshbm.Model.from_arrays(**a)
    a = bar_arrays()
    a["harmonic_load"] = np.zeros(3)
    with pytest.raises(mshbm.ModelError, match="load.harmonic"):
        mshbm.Model.from_arrays(**a)
    a = bar_arrays()
    a["damping"] = {"zeta": 0.01}
    with pytest.raises(mshbm.ArgumentError, match="zeta"):
        mshbm.Model.from_arrays(**a)


# --- arguments: ArgumentError with the CLI's words; not converged: NotConvergedError ---

@pytest.fixture(scope="module")
def bar():
    return mshbm.Model.from_toml(BAR, {"damping.first_mode_ratio": 0.01})


@pytest.mark.parametrize(
    "call, cli_args, words",
    [
        (lambda b: mshbm.solve(b, -1.0), ["solve", "--frequency=-1"], "must be a positive number of Hz, got -1"),
        (lambda b: mshbm.solve(b, 1000, 0), ["solve", "--frequency", 1000, "--harmonics", 0], "must be at least 1"),
        (lambda b: mshbm.solve(b, 1000, 5, samples=4), ["solve", "--frequency", 1000, "--samples", 4], "is too few for 5 harmonics: need at least 2H+1 = 11"),
        (lambda b: mshbm.solve(b, 1000, penalty=1e8), ["solve", "--frequency", 1000, "--penalty", "1e8"], "applies to"),
        (lambda b: mshbm.solve(b, 1000, method="hbm-aft", penalty="-3x"), ["solve", "--frequency", 1000, "--method", "hbm-aft", "--penalty=-3x"], "must be positive, got -3x"),
        (lambda b: mshbm.solve(b, 1000, dof=101), ["solve", "--frequency", 1000, "--dof", 101], "out of range: the model has DOFs 0..100"),
        (lambda b: mshbm.solve(b, 1000, tolerance=0), ["solve", "--frequency", 1000, "--tolerance", 0], "must be positive, got 0"),
        (lambda b: mshbm.frf(b, 1000, 1000), ["frf", "--from", 1000, "--to", 1000], "must differ"),
        (lambda b: mshbm.frf(b, 1000, 2000, step=1.0), ["frf", "--from", 1000, "--to", 2000, "--step", 1.0], "steps must satisfy 0 <"),
        (lambda b: mshbm.simulate(b, 1000, restitution=2.0, scheme="moreau"), ["simulate", "--frequency", 1000, "--restitution", 2, "--scheme", "moreau"], "must lie in [0, 1], got 2"),
    ],
)
def test_argument_errors_say_what_the_cli_says(cli, bar, call, cli_args, words):
    with pytest.raises(mshbm.ArgumentError) as info:
        call(bar)
    assert words in str(info.value)
    out = cli(cli_args[0], BAR, *cli_args[1:], check=False)
    assert out.returncode == 1 and words in out.stderr, out.stderr


def _neutral_cli(message):
    """A CLI message in neutral spelling: `--receptance-modes` -> `receptance_modes`,
    `--from`/`--to` -> `from_hz`/`to_hz`, `--from-solution` -> `start_solution`."""
    special = {"from": "from_hz", "to": "to_hz", "from-solution": "start_solution"}
    return re.sub(r"--([a-z][a-z-]*)", lambda m: special.get(m.group(1), m.group(1).replace("-", "_")), message)


def _neutral_python(message):
    """A Python message in neutral spelling: `receptance='modal'` -> `receptance modal`."""
    return re.sub(r"\b([a-z_]+)='([^']*)'", r"\1 \2", message)


@pytest.mark.parametrize(
    "call, cli_args, argument",
    [
        (lambda b: mshbm.solve(b, 1000, receptance_modes=5), ["solve", "--frequency", 1000, "--receptance-modes", 5], "receptance_modes"),
        (lambda b: mshbm.solve(b, 1000, max_iterations=0), ["solve", "--frequency", 1000, "--max-iterations", 0], "max_iterations"),
        (lambda b: mshbm.solve(b, 1000, method="mshbm", jacobian="dense"), ["solve", "--frequency", 1000, "--method", "mshbm", "--jacobian", "dense"], "jacobian"),
        (lambda b: mshbm.solve(b, 1000, method="hbm-aft", penalty="stiff"), ["solve", "--frequency", 1000, "--method", "hbm-aft", "--penalty", "stiff"], "penalty"),
        (lambda b: mshbm.solve(b, 1000, tangential_penalty="10x"), ["solve", "--frequency", 1000, "--tangential-penalty", "10x"], "tangential_penalty"),
        (lambda b: mshbm.solve(b, 1000, sweep_from=2000, sweep_to=3000), ["solve", "--frequency", 1000, "--sweep-from", 2000, "--sweep-to", 3000], "frequency"),
        (lambda b: mshbm.frf(b, -5, 2000), ["frf", "--from=-5", "--to", 2000], "from_hz"),
        (lambda b: mshbm.frf(b, 1000, 2000, min_step=0.5), ["frf", "--from", 1000, "--to", 2000, "--min-step", 0.5], "step"),
        (lambda b: mshbm.frf(b, 1000, 2000, overlay_mshbm=True), ["frf", "--from", 1000, "--to", 2000, "--overlay-mshbm"], "overlay_mshbm"),
        (lambda b: mshbm.simulate(b, 1000, theta=0.2, scheme="moreau"), ["simulate", "--frequency", 1000, "--theta", 0.2, "--scheme", "moreau"], "theta"),
        (lambda b: mshbm.simulate(b, 1000, steady_state=True, periods=1), ["simulate", "--frequency", 1000, "--steady-state", "--periods", 1], "periods"),
        (lambda b: mshbm.simulate(b, 1000, theta=0.6), ["simulate", "--frequency", 1000, "--theta", 0.6], "scheme"),
    ],
)
def test_the_same_bad_option_gets_the_same_words_from_both_front_ends(cli, bar, call, cli_args, argument):
    """The library's request layer (`mshbm::request`) words every option error once; the
    CLI and Python differ only in how they spell an option (`--receptance-modes`,
    `--receptance modal` against `receptance_modes`, `receptance='modal'`), and Python
    names the keyword at fault in `ArgumentError.argument`."""
    with pytest.raises(mshbm.ArgumentError) as info:
        call(bar)
    assert info.value.argument == argument
    out = cli(cli_args[0], BAR, *cli_args[1:], "--set", "damping.first_mode_ratio=0.01", check=False)
    assert out.returncode == 1, out.stderr
    cli_message = out.stderr.strip().removeprefix("error: ")
    assert _neutral_cli(cli_message) == _neutral_python(str(info.value)), (cli_message, str(info.value))


def test_the_exceptions_are_the_matching_built_ins(bar):
    """`except ValueError` catches a bad argument or model, `except RuntimeError` a failed
    computation, and each is still an `MshbmError`."""
    assert issubclass(mshbm.ArgumentError, ValueError) and issubclass(mshbm.ArgumentError, mshbm.MshbmError)
    assert issubclass(mshbm.ModelError, ValueError) and issubclass(mshbm.ModelError, mshbm.MshbmError)
    assert issubclass(mshbm.NotConvergedError, RuntimeError)
    assert issubclass(mshbm.NotConvergedError, mshbm.MshbmError)
    assert mshbm.ArgumentError.__module__ == "mshbm"
    with pytest.raises(ValueError) as info:
        mshbm.solve(bar, 1000, tolerance=-1.0)
    assert type(info.value) is mshbm.ArgumentError and info.value.argument == "tolerance"
    with pytest.raises(ValueError):
        mshbm.Model.from_toml("no/such/model.toml")
    with pytest.raises(RuntimeError):
        mshbm.solve(bar, 80000, 3, max_iterations=1, start="linear")
    # an argument error the request layer does not word names no keyword
    with pytest.raises(mshbm.ArgumentError) as info:
        mshbm.Model.from_toml(BAR, ["contact.gap"])
    assert info.value.argument is None


def test_unknown_choices_are_argument_errors(bar):
    with pytest.raises(mshbm.ArgumentError, match="method=.*expected one of 'redistributed', 'hbm-aft', 'mshbm'"):
        mshbm.solve(bar, 1000, method="newton")
    with pytest.raises(mshbm.ArgumentError, match="threads must be at least 1"):
        mshbm.solve(bar, 1000, threads=0)
    with pytest.raises(mshbm.ArgumentError, match="expected an mshbm.Model"):
        mshbm.solve("examples/clamped_bar.toml", 1000)


def test_not_converged_carries_the_cli_message_and_the_result(cli, bar):
    with pytest.raises(mshbm.NotConvergedError) as info:
        mshbm.solve(bar, 80000, 3, max_iterations=1, start="linear")
    message = str(info.value)
    assert message.startswith("Newton did not converge at 80000 Hz")
    assert not info.value.result.converged and info.value.result.iterations == 1
    out = cli("solve", BAR, "--frequency", 80000, "--harmonics", 3, "--max-iterations", 1, "--start", "linear",
              "--set", "damping.first_mode_ratio=0.01", check=False)
    assert out.returncode == 2 and f"error: {message}" in out.stderr, out.stderr


def test_a_start_from_another_method_or_model_is_refused_as_by_the_cli(cli, bar, general_model, tmp_path):
    """`solve(start=Solution)` refuses what `solve --from-solution` refuses, with the
    library's reason (`PeriodicSolution::unusable_start`): a solution of another method
    (the HBM-AFT's unknowns are not the redistributed MS-HBM's) and one of another model
    with as many unknowns (its contact elsewhere)."""
    aft = mshbm.solve(bar, 30000, 3, method="hbm-aft", stability=False)
    edit(general_model, "dofs = [100]", "dofs = [99]")
    other_model = mshbm.Model.from_toml(general_model / "model.toml")
    other = mshbm.solve(other_model, 30000, 3, stability=False)
    assert len(other.unknowns) == len(mshbm.solve(bar, 30000, 3, stability=False).unknowns)
    for start, reason in [
        (aft, "it is a solution of the method hbm-aft, not of redistributed: its unknowns mean something else"),
        (other, "it belongs to another model: it has 1 contacts at DOFs [99], the model 1 contacts at DOFs [100]"),
    ]:
        with pytest.raises(mshbm.ArgumentError) as info:
            mshbm.solve(bar, 30000, 3, start=start)
        message = str(info.value)
        assert message == f"start: cannot start from this solution: {reason}", message
        path = tmp_path / "start.json"
        path.write_text(start.to_json())
        out = cli("solve", BAR, *DAMPED_SET, "--frequency", 30000, "--harmonics", 3, "--from-solution", path, check=False)
        assert out.returncode == 1, out.stderr
        assert f"cannot start from this solution: {reason}" in out.stderr, out.stderr
    # the same method and model still start (and from another H)
    assert mshbm.solve(bar, 30000, 4, start=mshbm.solve(bar, 30000, 3)).converged
