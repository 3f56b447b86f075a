"""``scenesim data list | prepare`` through the console entry point."""

from __future__ import annotations

import pytest

from benchmarks.cli.main import main
from data_recipes.source import open_data


def test_data_list_shows_recipes_and_builtin_source(capsys, monkeypatch):
    monkeypatch.delenv("SCENESIM_DATA", raising=False)
    assert main(["data", "list"]) == 0
    out = capsys.readouterr().out
    for name in ("artificial-voice", "local", "cmu-arctic", "noisex92"):
        assert name in out
    assert "built-in" in out and "babble (synthesized)" in out


def test_data_list_with_shared_dir(capsys, shared_data_dir):
    assert main(["data", "list", "--data-dir", str(shared_data_dir)]) == 0
    out = capsys.readouterr().out
    assert "wind (file)" in out and "factory (synthesized)" in out


def test_prepare_artificial_voice_makes_a_usable_data_dir(tmp_path, capsys):
    dest = tmp_path / "av"
    assert main(["data", "prepare", "artificial-voice", "--dest", str(dest)]) == 0
    assert len(list((dest / "speech").glob("*.wav"))) == 6
    assert (dest / "manifest.json").is_file()
    assert "9 file(s)" in capsys.readouterr().out  # 6 talkers + babble/factory/wind
    ds = open_data(dest)
    assert ds.speech(1.0, seed=0).source.startswith("local:")
    assert set(ds.local_noise_types) == {"babble", "factory", "wind"}


def test_prepare_cmu_arctic_offline_is_a_clean_error(tmp_path, capsys):
    code = main(["data", "prepare", "cmu-arctic", "--dest", str(tmp_path / "c"),
                 "--base-url", "http://127.0.0.1:9/"])
    assert code == 2
    assert "--data-dir" in capsys.readouterr().err
    assert not (tmp_path / "c").exists()


def test_unknown_recipe_is_reported(capsys):
    assert main(["data", "prepare", "nonesuch"]) == 2
    assert "recipe" in capsys.readouterr().err


def test_option_the_recipe_does_not_take_is_named(tmp_path, capsys):
    code = main(["data", "prepare", "artificial-voice", "--dest", str(tmp_path), "--talkers", "bdl"])
    assert code == 2
    assert "talkers" in capsys.readouterr().err


@pytest.mark.parametrize("recipe", ["local", "noisex92"])
def test_prepare_without_src_names_the_option_and_how_to_give_it(tmp_path, capsys, recipe):
    from benchmarks.cli.main import main

    assert main(["data", "prepare", recipe, "--dest", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err.strip()
    assert f"the {recipe} recipe needs --src DIR" in err and "None" not in err and "\n" not in err
    assert not (tmp_path / "d").exists()  # refused before anything was created
