"""Worked answers for splicer.io.config: the documented example file, frame numbers from
frames or seconds, and errors that name the file and line."""

import textwrap

import pytest

import splicer.io.config as constraints_module
from splicer.io.config import PairSpec, frame_number, parse_config, read_config
from splicer.errors import ConstraintError


def _docstring_example() -> str:
    """The example in the module docstring, as a user would copy it."""
    doc = constraints_module.__doc__
    block = doc[doc.index("# sync.yaml"):doc.index("Errors name")]
    return textwrap.dedent("    " + block)


def test_the_documented_example_parses_to_its_worked_values():
    cfg = parse_config(_docstring_example(), "sync.yaml")
    assert cfg.source == "sync.yaml"
    assert cfg.tolerance == 2
    # line 1 is the '# sync.yaml' comment; the pairs start on lines 5 and 6
    assert cfg.pairs == (
        PairSpec(body=120, hands=251, tolerance=None, side="both", line=5, index=0),
        PairSpec(body="4.2s", hands="9.0s", tolerance=0, side="right", line=6, index=1),
    )
    assert cfg.joints == {
        "body": {"left": {"wrist": "L_Wrist", "elbow": "L_Elbow", "upper_arm": "L_UpperArm"}},
        "hands": {"right": {"wrist": "WRIST", "fingers": {"index": ["INDEX_MCP", "INDEX_PIP_FE", "INDEX_DIP_FE"]}}},
    }
    assert cfg.up == {"body": "y", "hands": "z"}
    assert cfg.hands_side == "left"


def test_frame_numbers_from_frames_and_seconds():
    assert frame_number(120, 60.0, what="x") == 120
    assert frame_number(7.0, 60.0, what="x") == 7
    assert frame_number(" 42 ", 60.0, what="x") == 42
    assert frame_number("4.2s", 120.0, what="x") == 504        # 4.2 x 120
    assert frame_number("9.0s", 59.94, what="x") == 539        # 539.46 rounds down
    assert frame_number("0.05s", 90.0, what="x") == 4          # 4.5 rounds to even: 4
    assert frame_number("1e1 s", 30.0, what="x") == 300
    for bad in (True, 2.5, "4.2", "-3", "4.2 ms", None):
        with pytest.raises(ConstraintError, match="^x: "):
            frame_number(bad, 60.0, what="x")


def test_side_and_tolerance_defaults():
    cfg = parse_config("side: left\npairs:\n  - {body: 10, hands: 20}\n  - {body: 30, hands: 40, side: both}\n")
    assert [p.side for p in cfg.pairs] == ["left", "both"]
    assert cfg.tolerance == 0 and cfg.joints == {} and cfg.up == {} and cfg.hands_side is None
    assert parse_config("up: Z\n").up == {"body": "z", "hands": "z"}
    assert parse_config("").pairs == () and parse_config("pairs:\n").pairs == ()
    assert parse_config("tolerance: 0.1s\n").tolerance == "0.1s"


@pytest.mark.parametrize("text,line,words", [
    ("pairs:\n  - {body: 10, hands: 20}\n  - {body: 1.5, hands: 20}\n", 3, "pair 2"),
    ("pairs:\n  - {body: 10, hand: 20}\n", 2, "unknown key 'hand'"),
    ("pairs:\n  - {body: 10}\n", 2, "missing 'hands'"),
    ("pairs:\n  - {body: -4, hands: 20}\n", 2, "negative"),
    ("pairs:\n  - {body: 4, hands: 20, tolerance: -1}\n", 2, "tolerance"),
    ("pairs:\n  - {body: 4, hands: 20, side: middle}\n", 2, "side"),
    ("pairs:\n  - 12\n", 2, "pair 1"),
    ("\n\nsides: left\n", 3, "unknown key 'sides'"),
    ("side: up\n", 1, "side must be left, right or both"),
    ("tolerance: 1.5\n", 1, "whole number of frames"),
    ("pairs: {body: 1}\n", 1, "'pairs' must be a list"),
    ("up: w\n", 1, "'up' is x, y or z"),
    ("hands_side: both\n", 1, "hands_side must be left or right"),
    ("joints: {feet: {}}\n", 1, "'joints' takes"),
    ("pairs: [\n", 2, "not valid YAML"),
])
def test_errors_name_the_file_and_line(text, line, words):
    with pytest.raises(ConstraintError) as e:
        parse_config(text, "sync.yaml")
    msg = str(e.value)
    assert msg.startswith(f"sync.yaml, line {line}"), msg
    assert words in msg, msg
    assert "\n" not in msg


def test_read_config_reads_a_file_and_names_missing_ones(tmp_path):
    p = tmp_path / "sync.yaml"
    p.write_text("pairs:\n  - {body: 10, hands: 20}\n", encoding="utf-8")
    cfg = read_config(p)
    assert cfg.source == str(p) and cfg.pairs[0].body == 10 and cfg.pairs[0].line == 2
    with pytest.raises(ConstraintError, match="not found"):
        read_config(tmp_path / "missing.yaml")
    with pytest.raises(ConstraintError, match="is a directory"):
        read_config(tmp_path)
