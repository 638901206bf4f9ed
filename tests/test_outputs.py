"""Outputs of a run: output folders, Markdown and CSV tables, caption sidecars, atomic writes."""

import pandas as pd
import pytest

import lnss_lib.outputs as outputs_module
import lnss_lib.pipeline as pipeline
from lnss_lib.outputs import (
    markdown_table,
    output_dir,
    read_caption,
    save_table,
    write_caption,
    write_text_atomic,
)


@pytest.fixture
def outputs(tmp_path, monkeypatch):
    monkeypatch.setattr(outputs_module, "OUTPUTS_DIR", tmp_path)
    return tmp_path


def test_markdown_table_cells_and_index_ignores_sidecars(outputs):
    import numpy as np

    frame = pd.DataFrame(
        {"n": [3, 12], "pdop": [2.123456, np.nan], "why": ["a|b", "c"]},
        index=pd.Index(["x", "y"], name="design"),
    )
    lines = markdown_table(frame, digits=3).splitlines()
    assert lines[0] == "| design | n | pdop | why |" and lines[1] == "|---|---|---|---|"
    assert lines[2] == "| x | 3 | 2.12 | a\\|b |" and lines[3] == "| y | 12 |  | c |"
    save_table(frame, "t", "tab", caption="multi\nline  caption")
    assert pd.read_csv(outputs / "t" / "tables" / "tab.csv", index_col=0).index.tolist() == [
        "x",
        "y",
    ]
    page = pipeline.write_index("t").read_text()
    assert "multi line caption" in page and ".meta.json" not in page


def test_save_table_writes_csv_markdown_and_caption(outputs):
    written = save_table(
        pd.DataFrame({"x": [1.0, 2.5]}), "t", "table_a", caption="Table A: two numbers"
    )
    assert set(written) == {"csv", "md", "meta"}
    assert written["csv"].read_text().splitlines() == [
        "x",
        "1.0",
        "2.5",
    ]  # a plain index is not written
    assert read_caption(written["csv"].parent, "table_a") == "Table A: two numbers"
    assert read_caption(written["csv"].parent, "no_sidecar_here") == "no sidecar here"
    assert not [p for p in written["csv"].parent.iterdir() if p.name.endswith(".tmp")]


def test_output_dir_rejects_unknown_kind(outputs):
    assert (
        output_dir("t", "figures") == outputs / "t" / "figures"
        and (outputs / "t" / "figures").is_dir()
    )
    with pytest.raises(
        ValueError, match="unknown output kind 'plots'; allowed: notebooks, figures"
    ):
        output_dir("t", "plots")


def test_caption_sidecar_collapses_whitespace(tmp_path):
    path = write_caption(tmp_path, "f", "two\n  lines", [tmp_path / "f.html"])
    assert path.name == "f.meta.json" and read_caption(tmp_path, "f") == "two lines"


def test_atomic_write_replaces_whole_file(tmp_path):
    target = tmp_path / "a.txt"
    target.write_text("old content that is longer")
    assert write_text_atomic(target, "new") == target
    assert target.read_text() == "new" and [p.name for p in tmp_path.iterdir()] == ["a.txt"]


def test_tables_write_each_quantity_in_its_own_format_with_labelled_headers(outputs):
    frame = pd.DataFrame(
        {
            "sma_km": [19100.4, 6143.0],
            "pdop_mean_3sigma": [2.16195, 40.0],
            "dv_total_kms_per_year": [2.39526, 0.5],
            "pdop_avail_pct": [99.99999999999999, 70.0],
            "other": [1.23456789, 2.0],
        }
    )
    lines = markdown_table(frame).splitlines()
    assert lines[0] == (
        "| semi-major axis (km) | PDOP (3-sigma mean) | Delta-V total (km/s/yr) | PDOP availability (%) "
        "| other |"
    )
    assert lines[2] == "| 19100 | 2.16 | 2.395 | 100.0 | 1.235 |"  # not 1.91e+04, not 6 digits
    save_table(frame, "t", "formats", caption="formats")
    page = pipeline.write_index("t").read_text()
    assert (
        "<td>19100</td><td>2.16</td><td>2.395</td><td>100.0</td><td>1.235</td>" in page
        and '<th title="sma_km">semi-major axis (km)</th>' in page
    )


def test_records_show_workbook_paths_and_formatted_tables():
    import numpy as np

    from lnss_lib.config import PROJECT_DIR
    from lnss_lib.outputs import display_path, display_table

    assert display_path(PROJECT_DIR / "outputs" / "quick" / "campaign") == "outputs/quick/campaign"
    assert display_path("/somewhere/else/run_1") == "run_1"  # never a machine's absolute prefix
    frame = pd.DataFrame(
        {"sma_km": [19100.4], "ecc": [0.6], "impact_day": [np.nan], "region": ["frozen family"]}
    )
    shown = display_table(frame, ["sma_km", "impact_day", "region"])
    assert list(shown.columns) == ["semi-major axis (km)", "first satellite lost (day)", "region"]
    assert shown.iloc[0].tolist() == ["19100", "-", "frozen family"]
    by_frame = (
        pd.DataFrame(  # index name, row keys and a column level's name are read as their labels
            {"dv_total_kms_per_year": [1.25, 2.5]},
            index=pd.Index(["lunar_equator_of_epoch", "not a key"], name="step_s"),
        )
    )
    by_frame.columns.name = "model_all"
    shown = display_table(by_frame)
    assert shown.index.tolist() == ["lunar equator of epoch", "not a key"]
    assert (shown.index.name, shown.columns.name) == ("sampling step (s)", "Delta-V model")


def test_mask_suffixed_keys_keep_their_label_and_format():
    from lnss_lib.keys import format_value, label

    assert label("pdop_avail_pct_mask20deg") == "PDOP availability (%), 20 deg mask"
    assert format_value("mean_visible_sats_mask5deg", 11.33671) == "11.34"
    assert label("table4_elfo_mask") == "table4_elfo_mask"  # not a key: unchanged


def test_the_validated_fronts_keys_read_as_words_with_units():
    from lnss_lib.campaign.validation import CLOSED_LOOP_KEYS
    from lnss_lib.keys import format_value, label

    assert (
        label("closed_loop_dv_relative_node_kms_per_year")
        == "closed-loop Delta-V, relative node (km/s/yr)"
    )
    assert (
        label("closed_loop_dv__kms_per_year") == "closed_loop_dv__kms_per_year"
    )  # no purpose: not a key
    assert all(label(k) != k for k in CLOSED_LOOP_KEYS)
    assert format_value("pdop_avail_pct_life", 92.1617) == "92.2"
    assert format_value("closed_loop_dv_max_kms_per_year", 0.99412) == "0.994"


def test_cached_json_computes_once_per_inputs_code_and_data(tmp_path, monkeypatch):
    import math

    import numpy as np

    from lnss_lib import outputs

    calls = []

    def compute():
        calls.append(1)
        return {
            "dv": np.float64(0.25),
            "n": np.int64(3),
            "held": True,
            "impact_day": math.nan,
            "region": "x",
        }

    first, hit = outputs.cached_json(tmp_path, "row", ["hash", [1.0, 2]], compute)
    assert not hit and len(calls) == 1
    again, hit = outputs.cached_json(tmp_path, "row", ["hash", [1.0, 2]], compute)
    assert hit and len(calls) == 1  # read back, not computed
    assert (
        again["dv"] == 0.25
        and again["n"] == 3
        and again["held"] is True
        and math.isnan(again["impact_day"])
    )
    outputs.cached_json(tmp_path, "row", ["other hash", [1.0, 2]], compute)
    assert len(calls) == 2  # other inputs
    monkeypatch.setattr(outputs, "code_and_data_digest", lambda: "edited")
    assert (
        outputs.cached_json(tmp_path, "row", ["hash", [1.0, 2]], compute)[1] is False
        and len(calls) == 3
    )
    for path in tmp_path.glob("row_*.json"):
        path.write_text('{"torn')  # a damaged file is computed again
    assert (
        outputs.cached_json(tmp_path, "row", ["hash", [1.0, 2]], compute)[1] is False
        and len(calls) == 4
    )
    assert outputs.cached_json(None, "row", ["hash"], compute) == (compute(), False)


def test_notebook_tables_show_labels_and_each_quantitys_format():
    import numpy as np
    import pandas as pd

    from lnss_lib.outputs import reader_html

    frame = pd.DataFrame(
        {
            "pdop_mean_3sigma": [2.123456, np.nan],
            "n_sat": [12.0, 8.0],
            "dv_total_kms_per_year": [0.2534567, 1.0],
            "why": ["a", "b"],
        }
    )
    page = reader_html(frame)
    assert (
        "<th>PDOP (3-sigma mean)</th>" in page
        and "<th>satellites</th>" in page
        and "pdop_mean_3sigma" not in page
    )
    assert (
        "<td>2.12</td>" in page
        and "<td>-</td>" in page
        and "<td>12</td>" in page
        and "<td>0.253</td>" in page
    )
    with pd.option_context("display.max_rows", 1):
        assert "first 1 of 2 rows" in reader_html(frame) and "<td>8</td>" not in reader_html(frame)
    assert "<td>1</td>" in reader_html(
        pd.DataFrame([[1.0, 2.0]], columns=["x", "x"])
    )  # duplicate names still shown
