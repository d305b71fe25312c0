"""JSON that the parser cannot hold (arrays nested thousands deep, an integer of thousands of digits) in a Sensor
Logger JSON export, a hand-tracking log or a model's metadata: one line naming the file, exit status 2 on the
command line, never a traceback."""

import pytest
from typer.testing import CliRunner

from spotfree.cli import app
from spotfree.errors import InputError
from spotfree.hand.log import parse_log

runner = CliRunner()
NESTED = "[" * 100_000 + "]" * 100_000
BIG = '[{"sensor": "Accelerometer", "time": ' + "9" * 5000 + ', "x": 1, "y": 2, "z": 3}]'


@pytest.mark.parametrize("text, reason", [(NESTED, "nested too deeply"), (BIG, "a number too long")])
def test_a_sensor_logger_json_export_the_parser_cannot_hold(tmp_path, text, reason):
    path = tmp_path / "ride.json"
    path.write_text(text)
    result = runner.invoke(app, ["features", str(path), "-o", str(tmp_path / "f.csv")])
    assert result.exit_code == 2 and reason in result.output, result.output
    assert len(result.output.strip().splitlines()) == 1 and "Traceback" not in result.output


@pytest.mark.parametrize("line, reason", [(NESTED, "nested too deeply"),
                                          ('{"timestamp": ' + "9" * 5000 + "}", "a number too long")])
def test_a_hand_log_line_the_parser_cannot_hold(line, reason):
    with pytest.raises(InputError, match=f"hand.jsonl, line 1: .*{reason}"):
        parse_log(line + "\n", "hand.jsonl")


@pytest.mark.parametrize("metadata", [NESTED, '{"rate": ' + "9" * 5000 + "}"])
def test_a_model_whose_metadata_the_parser_cannot_hold(tmp_path, metadata):
    import numpy as np

    from spotfree.model import DictionaryModel

    path = tmp_path / "model.npz"
    np.savez(path, metadata=np.array(metadata), dictionary=np.eye(3), column_class=np.zeros(3, dtype=int),
             scale=np.ones(1))
    with pytest.raises(InputError, match="model.npz.*metadata is not a JSON object"):
        DictionaryModel.load(path)


@pytest.mark.parametrize("where, timestamp, message", [
    (25, -1e30, "field 'timestamp' must be the frame time in microseconds"),
    (25, 1e30, "field 'timestamp' must be the frame time in microseconds"),
    (49, 1e15, "its frames span 1e\\+09 s, more than 172800 s"),  # 31 years: a grid of 20 billion samples
])
def test_a_hand_timestamp_far_out_is_one_line_not_a_huge_grid(tmp_path, where, timestamp, message):
    import json

    from spotfree.hand.log import read_hand_log
    from test_hand_frames import SERVICE_FRAME

    frames = [{**json.loads(json.dumps(SERVICE_FRAME)), "timestamp": k * 10_000, "id": k} for k in range(50)]
    frames[where]["timestamp"] = timestamp
    path = tmp_path / "hand.jsonl"
    path.write_text("".join(json.dumps(f) + "\n" for f in frames))
    with pytest.raises(InputError, match=message):
        read_hand_log(path)
