"""btfstudio.run: the CLI's requests from Python — the same bytes, the same reports, the same
one-line errors, a progress callback that can cancel, docstrings from the declarations."""

import json

import numpy as np
import pytest

import btfstudio
from conftest import btfsim, scene

SMALL = dict(texels=6, dirs="4x8", spp=1)


def test_simulate_writes_the_bytes_of_btfsim_and_reports_what_it_json_prints(tmp_path):
    a, b = tmp_path / "cli.btf", tmp_path / "py.btf"
    _, out, _ = btfsim("simulate", scene("spheres"), "-o", a, "--texels", "6", "--dirs", "4x8",
                       "--spp", "1", "-q", "--json")
    seen = []
    rep = btfstudio.run("simulate", scene=scene("spheres"), output=str(b), **SMALL,
                        progress=lambda s, d, t: seen.append((s, d, t)))
    assert a.read_bytes() == b.read_bytes()
    cli = json.loads(out[out.index("{"):])
    assert list(rep) == list(cli)
    # The same request echoed (but the output path and the CLI's -q --json).
    differ = {k for k in cli["request"] if cli["request"][k] != rep["request"][k]}
    assert differ == {"output", "quiet", "json"}, differ
    assert rep["texels"] == cli["texels"] and rep["output_bytes"] == cli["output_bytes"]
    # Progress reached the callback with stages and counters.
    assert seen and all(t >= 1 and 0 <= d <= t for _, d, t in seen)
    assert any(s for s, _, _ in seen)


def test_every_command_is_a_function_with_its_declared_options():
    decls = btfstudio.commands()
    for name in ("simulate", "compress", "compare", "study", "export", "render", "plan", "info",
                 "slice", "bench", "brdf"):
        assert name in decls
        f = getattr(btfstudio, name)
        for o in decls[name]["options"]:
            if o["name"] not in ("quiet", "json"):
                assert f"    {o['name']} (" in f.__doc__, (name, o["name"])
    assert "in 1..64" in btfstudio.simulate.__doc__  # spp's range


def test_plan_and_info_return_their_reports(tmp_path, files):
    rep = btfstudio.plan(scene=scene("brick"), texels=8, dirs="4x8")
    assert rep["estimate"]["seconds"] > 0
    info = btfstudio.info(btf=str(files["raw"]))
    assert info["texels"] == [8, 6] and info["directions"]["count"] == 32


@pytest.mark.parametrize("options, message", [
    (dict(spp=0), "--spp: must be in 1..64 (got 0)"),
    (dict(texels="abc"), "--texels"),
    (dict(shadows="sometimes"), "--shadows"),
    (dict(colours="blue"), "simulate: unknown option 'colours'"),
])
def test_a_bad_option_raises_with_the_clis_message(tmp_path, options, message):
    args = ["simulate", scene("brick"), "-o", tmp_path / "x.btf"]
    for k, v in options.items():
        args += [f"--{k}", v]
    code, _, err = btfsim(*args, check=False)
    with pytest.raises(btfstudio.BtfError) as e:
        btfstudio.run("simulate", scene=scene("brick"), output=str(tmp_path / "x.btf"), **options)
    assert message in str(e.value)
    if message.startswith("--"):  # the CLI's words (exit 2 when refused before the run)
        assert code in (1, 2) and err.strip() == f"btfsim: error: {e.value}"
    assert not (tmp_path / "x.btf").exists()


def test_a_missing_scene_and_unknown_command(tmp_path):
    with pytest.raises(btfstudio.BtfError, match="no-such.json"):
        btfstudio.run("simulate", scene=str(tmp_path / "no-such.json"), output=str(tmp_path / "o"))
    with pytest.raises(btfstudio.BtfError, match="unknown command 'simulat'"):
        btfstudio.run("simulat")


def test_cancel_from_the_progress_callback_leaves_no_file(tmp_path):
    out = tmp_path / "c.btf"
    calls = []

    def stop(stage, done, total):
        calls.append(stage)
        return False

    with pytest.raises(btfstudio.Cancelled, match="cancelled"):
        btfstudio.run("simulate", scene=scene("weave"), output=str(out), texels=48, dirs="8x16",
                      progress=stop)
    assert calls
    assert not out.exists() and not (tmp_path / "c.btf.partial").exists()
    assert list(tmp_path.iterdir()) == []


def test_an_exception_in_the_callback_cancels_and_propagates(tmp_path):
    out = tmp_path / "e.btf"

    def boom(stage, done, total):
        raise ValueError("from the callback")

    with pytest.raises(ValueError, match="from the callback"):
        btfstudio.run("simulate", scene=scene("weave"), output=str(out), texels=48, dirs="8x16",
                      progress=boom)
    assert list(tmp_path.iterdir()) == []


def test_notes_receive_the_plan_and_compress_compare_round_trip(tmp_path, files):
    lines = []
    out = tmp_path / "n.cbtf"
    rep = btfstudio.compress(input=str(files["raw"]), output=str(out), codec="svd",
                             compare=True, notes=lines.append)
    assert out.exists() and rep["ratio"] > 1
    c = btfstudio.compare(a=str(files["raw"]), b=str(out))
    assert abs(c["relative_rmse"] - rep["error"]["relative_rmse"]) < 1e-9
    ref = btfstudio.open(files["raw"]).brdf()
    got = btfstudio.open(out).brdf()
    assert np.sqrt(np.mean((got - ref) ** 2)) / np.sqrt(np.mean(ref ** 2)) < 0.5
