"""A user's datasets.yaml layered over the packaged one (issue 24 item 1): what it inherits, what wins,
how lists and mappings combine, what `null` removes, where errors and `config show` say values came from."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from synthcal.cli import main
from synthcal.config import ConfigError, load_config, packaged_config_path

ROOT = Path(__file__).resolve().parents[1]
MINE = {"scene": "intersection-2", "grid": "intersection", "pool_size": 100}


@pytest.fixture(scope="module")
def packaged() -> dict:
    """The packaged file as plain YAML, read independently of synthcal's loader."""
    return yaml.safe_load((ROOT / "datasets.yaml").read_text())


def write(folder: Path, data: dict, name: str = "minimal.yaml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


def test_the_repository_file_is_the_packaged_one_and_is_read_alone():
    config = load_config(ROOT / "datasets.yaml")
    assert config.layers == (packaged_config_path(),)


def test_a_minimal_file_loads_and_inherits_grids_defaults_and_profiles(tmp_path, capsys, packaged):
    path = write(tmp_path, {"scenes": {}, "datasets": {"mine": MINE}})
    config = load_config(path)
    whole = load_config(ROOT / "datasets.yaml")
    assert config.layers == (packaged_config_path(), path)
    assert config.config.grids == whole.config.grids and config.config.profiles == whole.config.profiles
    assert config.dataset_names == [*packaged["datasets"], "mine"]  # listed alongside the packaged ones
    spec = config.resolve("mine", "smoke")
    assert spec.pool_size == min(100, packaged["profiles"]["smoke"]["max_pool_size"])
    assert list(spec.image_size) == packaged["profiles"]["smoke"]["image_size"]
    assert main(["datasets", "--config", str(path)]) == 0
    out = capsys.readouterr().out
    assert "\nmine " in out and "\nintersection-1 " in out


def test_the_resolved_spec_is_that_of_a_full_copy(tmp_path, packaged):
    """What a store records (the resolved spec, its hash) does not depend on how the file was written."""
    layered = load_config(write(tmp_path / "a", {"datasets": {"mine": MINE}}))
    full = packaged | {"datasets": packaged["datasets"] | {"mine": MINE}}
    copy = load_config(write(tmp_path / "b", full))
    assert layered.resolve("mine", "smoke") == copy.resolve("mine", "smoke")
    assert layered.resolve("mine").config_hash() == copy.resolve("mine").config_hash()


def test_a_key_set_in_both_is_the_users(tmp_path, packaged):
    path = write(tmp_path, {"defaults": {"seed": 9}, "profiles": {"smoke": {"shard_size": 4}},
                            "datasets": {"soccer": {"pool_size": 300}}})
    spec = load_config(path).resolve("soccer", "smoke")
    assert spec.seed == 9 and spec.shard_size == 4
    assert spec.pool_size == min(300, packaged["profiles"]["smoke"]["max_pool_size"])
    plain = load_config(path).resolve("soccer")
    assert plain.pool_size == 300 and plain.shard_size == packaged["defaults"]["shard_size"]
    # the rest of the packaged soccer entry stays: its scene and grid
    assert plain.scene == packaged["datasets"]["soccer"]["scene"]
    assert plain.grid == load_config(ROOT / "datasets.yaml").config.grids[packaged["datasets"]["soccer"]["grid"]]


def test_lists_replace_whole(tmp_path, packaged):
    path = write(tmp_path, {"defaults": {"split_seeds": [3]},
                            "mixed_dictionaries": {"intersection-1": ["intersection-5"]}})
    config = load_config(path)
    assert list(config.resolve("intersection-1").split_seeds) == [3]
    assert list(config.resolve("intersection-1").mixed_sources) == ["intersection-5"]
    assert list(config.resolve("intersection-4").mixed_sources) == packaged["mixed_dictionaries"]["intersection-4"]


def test_mappings_merge_at_every_depth(tmp_path, packaged):
    path = write(tmp_path, {"defaults": {"appearance": {"noise_sigma": 1.5}},
                            "profiles": {"smoke": {"training": {"unet_epochs": 5}}}})
    config = load_config(path)
    training = config.training("smoke")
    assert training.unet_epochs == 5
    assert training.siamese_width == packaged["profiles"]["smoke"]["training"]["siamese_width"]
    appearance = config.resolve("soccer").appearance
    assert appearance.noise_sigma == 1.5 and appearance.brightness == packaged["defaults"]["appearance"]["brightness"]


def test_null_removes_a_packaged_entry(tmp_path, packaged):
    config = load_config(write(tmp_path, {"profiles": {"paper": None},
                                          "datasets": {"worldcup2014": None, "mine": MINE},
                                          "defaults": {"splits": {"dictionary": None}}}))
    assert "paper" not in config.config.profiles and "smoke" in config.config.profiles
    assert "worldcup2014" not in config.dataset_names and "soccer" in config.dataset_names
    with pytest.raises(ConfigError, match="unknown profile 'paper'"):
        config.profile("paper")
    # a removed setting falls back to the schema's default
    from synthcal.config import SplitSizes

    assert config.resolve("mine").splits.dictionary == SplitSizes().dictionary


def test_removing_an_entry_others_name_is_an_error_naming_the_packaged_key(tmp_path):
    path = write(tmp_path, {"datasets": {"intersection-2": None}})
    with pytest.raises(ConfigError) as info:
        load_config(path)
    message = str(info.value)
    assert message.startswith(f"{packaged_config_path()}: mixed_dictionaries.intersection-1:")
    assert "'intersection-2' must be another dataset" in message


@pytest.mark.parametrize(("data", "key"), [
    ({"datasets": {"mine": MINE | {"pool_size": 0}}}, "datasets.mine.pool_size"),
    ({"datasets": {"mine": {"scene": "intersection-2", "grid": "intersection"}}}, "datasets.mine"),
    ({"profiles": {"smoke": {"training": {"unet_epochs": -1}}}}, "profiles.smoke.training.unet_epochs"),
    ({"grids": {"soccer": {"pan_deg": {"stpe": 1}}}}, "grids.soccer.pan_deg.stpe"),
    ({"datasets": {"mine": MINE | {"grid": "nowhere"}}}, "datasets.mine.grid"),
    ({"datasets": {"soccer": {"pool_size": 10**6}}}, "datasets.soccer.pool_size"),
])
def test_errors_name_the_users_file(tmp_path, capsys, data, key):
    path = write(tmp_path, data)
    assert main(["datasets", "--config", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"synthcal: error: {path}: {key}"), err


def test_scene_paths_are_relative_to_the_users_file(tmp_path):
    path = write(tmp_path / "sub", {"scenes": {"mine": {"image": "a.png", "semantic": "pics/b.png"}}})
    scene = load_config(path).config.scenes["mine"]
    assert (scene.image, scene.semantic) == (tmp_path / "sub" / "a.png", tmp_path / "sub" / "pics" / "b.png")


def _leaves(data: dict, prefix: tuple[str, ...] = ()) -> dict[tuple[str, ...], object]:
    """Every leaf key path of a YAML mapping (lists and empty mappings are leaves)."""
    out: dict[tuple[str, ...], object] = {}
    for key, value in data.items():
        if isinstance(value, dict) and value:
            out.update(_leaves(value, (*prefix, str(key))))
        else:
            out[(*prefix, str(key))] = value
    return out


def _commented_leaves(text: str) -> dict[tuple[str, ...], str]:
    """key path → the trailing comment of each `key: value  # origin` line, from the indentation."""
    stack: list[str] = []
    found = {}
    for line in text.splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        depth = (len(line) - len(line.lstrip())) // 2
        key = line.strip().split(":")[0].strip("'\"")
        stack[depth:] = [key]
        if "  # " in line:
            found[tuple(stack)] = line.rsplit("  # ", 1)[1]
    return found


def test_config_show_prints_the_merged_yaml_with_each_values_origin(tmp_path, capsys, packaged):
    user = {"defaults": {"seed": 9, "split_seeds": [1, 2]}, "profiles": {"smoke": {"training": {"unet_epochs": 5}}},
            "datasets": {"mine": MINE}}
    path = write(tmp_path, user)
    assert main(["config", "show", "--config", str(path)]) == 0
    text = capsys.readouterr().out
    assert yaml.safe_load(text) == load_config(path).raw
    origins = _commented_leaves(text)
    merged = _leaves(yaml.safe_load(text))
    assert set(origins) == set(merged)
    mine = set(_leaves(user))
    assert {key for key, origin in origins.items() if origin == str(path)} == mine
    assert all(origin == "packaged" for key, origin in origins.items() if key not in mine)
    assert ("grids", "soccer", "pan_deg", "step") in origins  # inherited values are shown too


def test_config_init_writes_a_starter_that_loads_and_never_overwrites(tmp_path, capsys):
    path = tmp_path / "my.yaml"
    assert main(["config", "init", str(path)]) == 0
    text = path.read_text()
    assert text.count("\n#") >= 5  # commented
    config = load_config(path)
    assert config.layers[-1] == path and "my-intersection" in config.dataset_names
    config.resolve("my-intersection", "smoke")
    assert main(["config", "init", str(path)]) == 2
    assert "exists" in capsys.readouterr().err and path.read_text() == text


def test_a_store_from_a_layered_file_reads_back(tmp_path, capsys):
    """Splits are drawn from the configuration the store recorded; it must validate again."""
    path = write(tmp_path, {"datasets": {"mine": {"scene": "soccer", "grid": "soccer", "pool_size": 16}}})
    out = tmp_path / "out"
    assert main(["generate", "mine", "--profile", "smoke", "--quiet", "--out", str(out), "--config", str(path)]) == 0
    store = str(out / "mine.zarr")
    assert main(["split", store, "--seeds", "3", "--train", "4", "--test", "2", "--dictionary", "4"]) == 0
    assert main(["verify", store]) == 0
    capsys.readouterr()


@pytest.mark.parametrize(("name", "weights"), [("unet30w.yaml", "inverse-frequency"), ("unet30.yaml", None)])
def test_the_reports_unet_layers_change_only_the_quick_unet(name, weights):
    """docs/sweeps' layers behind the report's UNet cells load, and set the quick profile's UNet and nothing else."""
    layered = load_config(ROOT / "docs" / "sweeps" / name).training("quick")
    bundled = load_config(ROOT / "datasets.yaml").training("quick")
    assert (layered.unet_epochs, layered.unet_class_weights) == (30, weights)
    assert layered.model_dump(exclude={"unet_epochs", "unet_class_weights"}) == \
        bundled.model_dump(exclude={"unet_epochs", "unet_class_weights"})
    assert bundled.unet_epochs != 30  # the layer is what sets it


def test_the_fixed_unet_rate_layer_is_unet30w_with_the_unets_rate_fixed():
    """docs/sweeps/unet30w_unetlr1e-3.yaml (slice step 52) is unet30w.yaml plus training.unet_learning_rate 1e-3."""
    fixed = load_config(ROOT / "docs" / "sweeps" / "unet30w_unetlr1e-3.yaml").training("quick")
    plain = load_config(ROOT / "docs" / "sweeps" / "unet30w.yaml").training("quick")
    assert fixed.unet_learning_rate == 1e-3 and plain.unet_learning_rate is None
    assert fixed.model_dump(exclude={"unet_learning_rate"}) == plain.model_dump(exclude={"unet_learning_rate"})


def test_the_reports_stn_ceiling_layer_changes_only_the_quick_stn_epochs():
    """docs/sweeps/stn48.yaml (the report's STN-ceiling check) doubles the quick profile's STN epochs, nothing else."""
    layered = load_config(ROOT / "docs" / "sweeps" / "stn48.yaml").training("quick")
    bundled = load_config(ROOT / "datasets.yaml").training("quick")
    assert layered.stn_epochs == 2 * bundled.stn_epochs == 48
    assert layered.model_dump(exclude={"stn_epochs"}) == bundled.model_dump(exclude={"stn_epochs"})
