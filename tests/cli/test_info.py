"""filmgrain --help, --list-options, --version, --list-stocks, --print-stock."""

import json
import re

from conftest import FAST, Exr, listing, rgb_ramp, write_image

MODIFIERS = ["stock", "exposure_stops", "shutter_s", "seed", "frame", "static_grain", "edge", "width_mm", "scan", "roi",
             "engine", "tolerance", "kinetics", "photons", "coverage", "grains", "scale", "samples",
             "tile", "output", "timing"]

OPTIONS = ["--wedge", "--chart", "--subimage", "--view", "--ch", "--colorconfig", "--iscolorspace",
           "--ocolorspace", "--filmgrain", "-d", "-o",
           "--frames", "--skip-existing", "--skip-missing", "--dry-run", "--report-json", "--stats", "--preview", "--threads", "--progress", "-q", "--quiet",
           "--list-stocks", "--list-options", "--print-stock", "--version", "--help"]


def modifier_lines(help_text):
    """{key: the help paragraph of :key=...} from the --filmgrain section."""
    section = help_text.split("--filmgrain modifiers")[1].split("\n\n")[0]
    entries = {}
    for block in re.split(r"\n(?=    :)", section):
        m = re.match(r"\s*:(\w+)=", block)
        if m:
            entries[m.group(1)] = " ".join(block.split())
    return entries


def test_help_lists_every_option_and_modifier_with_default(run):
    r = run("--help")
    assert r.returncode == 0, r.stderr
    text = r.stdout
    for opt in OPTIONS:
        assert re.search(r"^\s+" + re.escape(opt) + r"\b", text, re.M) or \
            (", " + opt) in text, opt
    mods = modifier_lines(text)
    assert sorted(mods) == sorted(MODIFIERS)
    for key, line in mods.items():
        assert "Default:" in line, (key, line)
    # The defaults are the library's (SceneSettings, RenderSettings, preset).
    assert "Default: vision3-500t." in mods["stock"]
    assert "Default: 0." in mods["exposure_stops"]
    assert "Default: 0.0208333 (1/48)." in mods["shutter_s"]
    assert "Default: 0." in mods["seed"]
    assert "Default: 24.89." in mods["width_mm"]
    assert "Default: auto." in mods["engine"]
    assert "Default: 64." in mods["tile"]
    # Presets, config resolution order, exit status.
    assert "vision3-500t (default), vision3-250d" in text
    order = [text.index(s) for s in ("1. --colorconfig", "2. $OCIO", "3. the embedded")]
    assert order == sorted(order)
    assert "Exit status" in text
    # -h is the same.
    assert run("-h").stdout == text


def test_list_options_is_the_help_as_json(run):
    """--list-options: the same options and modifiers --help lists, with the
    same defaults, as JSON (what filmgrain-farm reads)."""
    doc = json.loads(run("--list-options").stdout)
    names = [o["name"] for o in doc["options"]]
    spellings = names + [a for o in doc["options"] for a in o["aliases"]]
    assert sorted(spellings) == sorted(OPTIONS + ["-h"])
    by_name = {o["name"]: o for o in doc["options"]}
    assert by_name["--threads"]["value"] == "N" and by_name["--wedge"]["value"] == ""
    assert [n for n in names if by_name[n]["modifiers"]] == ["--filmgrain", "-o"]
    assert sorted(n for n in names if by_name[n]["prints_and_exits"]) == sorted(
        ["--list-stocks", "--list-options", "--print-stock", "--version", "--help"])
    mods = {m["key"]: m for m in doc["modifiers"]["--filmgrain"]}
    assert sorted(mods) == sorted(MODIFIERS)
    help_mods = modifier_lines(run("--help").stdout)
    for key, m in mods.items():  # the default --help prints, word for word
        assert f"Default: {m['default']}." in help_mods[key], key
    assert doc["modifiers"]["-o"][0]["default"] == "piz"


def test_help_wins_over_other_errors(run):
    r = run("--bogus", "--help")
    assert r.returncode == 0
    assert "Usage:" in r.stdout


def test_no_arguments_is_a_usage_error(run):
    r = run()
    assert r.returncode == 1
    assert "Usage:" in r.stderr


def test_version(run):
    r = run("--version")
    assert r.returncode == 0, r.stderr
    assert re.match(r"filmgrain \d+\.\d+\.\d+", r.stdout)


def test_list_stocks(run):
    r = run("--list-stocks")
    assert r.returncode == 0, r.stderr
    assert "vision3-500t (default)" in r.stdout
    assert re.search(r"^color-negative$", r.stdout, re.M)
    assert re.search(r"^paper$", r.stdout, re.M)
    # Each name is followed by its description.
    assert "Stephenson" in r.stdout


def test_unknown_option_is_an_error(run):
    r = run("--filmgrian")
    assert r.returncode == 1
    assert "filmgrain: error:" in r.stderr and "--filmgrian" in r.stderr


def test_info_options_do_not_combine_with_rendering(run, tmp_path):
    r = run("--list-stocks", "--wedge", "--filmgrain", "-o", tmp_path / "x.exr")
    assert r.returncode == 1
    assert "do not combine" in r.stderr
    assert listing(tmp_path) == []


def test_print_stock_is_json_that_round_trips(run, tmp_path):
    r = run("--print-stock", "paper")
    assert r.returncode == 0, r.stderr
    stock = json.loads(r.stdout)
    assert stock["name"] == "paper"
    assert len(stock["layers"]) == 1
    for key in ("exposure_at_grey_lxs", "development_time_s", "development_tau_s",
                "fog_tau_s", "base_density", "max_density"):
        assert key in stock, key
    pop = stock["layers"][0]["populations"][0]
    for key in ("grains_per_um2", "diameter_um", "diameter_log_sigma",
                "quantum_efficiency", "k_pair_per_s", "k_join_per_s", "k_loss_per_s",
                "rate_area_exponent"):
        assert key in pop, key

    # The printed JSON is a stock file: printing it again gives the same...
    path = tmp_path / "paper.json"
    path.write_text(r.stdout)
    again = run("--print-stock", path)
    assert again.returncode == 0, again.stderr
    assert json.loads(again.stdout) == stock

    # ...and rendering with it equals rendering with the preset.
    src = write_image(tmp_path / "in.exr", rgb_ramp())
    a, b = tmp_path / "a.exr", tmp_path / "b.exr"
    ra = run(src, f"--filmgrain:stock=paper:{FAST}", "-o", a)
    rb = run(src, f"--filmgrain:stock={path}:{FAST}", "-o", b)
    assert ra.returncode == 0 and rb.returncode == 0, ra.stderr + rb.stderr
    ea, eb = Exr(a), Exr(b)
    assert ea.names == eb.names == ["Y"]
    assert (ea.channels["Y"] == eb.channels["Y"]).all()
    assert json.loads(eb.attr("filmgrain:stock")) == stock


def test_print_stock_unknown(run):
    r = run("--print-stock", "no-such-stock")
    assert r.returncode == 1
    assert "no-such-stock" in r.stderr and "preset" in r.stderr
    assert r.stdout == ""
