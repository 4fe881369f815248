"""`tools/gait_from_mcap.py` on a recording of known gait, written in the shapes Centaur's
recorder writes (`src/recording.rs`: `foxglove.FrameTransforms` on /tf with the base first,
contact forces as `foxglove.SceneUpdate` arrows on /contacts, the step's metrics on /metrics).

The robot runs 10 s at 100 Hz along a heading of 0° or 90° (world +y, where the tool has
to name the feet in the heading frame, not the world's): a trot of period 0.5 s, the pairs FL+BR and
FR+BL each in stance for half the cycle, every foot touching down twice a second, the base at
0.2 m and 1.5 m/s. The reward is 0.01 per step; the commanded speed and the clock's rate are
constant.
"""

import importlib.util
import json
import math

import pytest

from conftest import REPO

from mcap.writer import Writer

DT, STEPS, PERIOD, SPEED = 0.01, 1000, 0.5, 1.5


def load_tool():
    spec = importlib.util.spec_from_file_location("gait_from_mcap", REPO / "tools" / "gait_from_mcap.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    return tool


def stamp(t):
    sec = math.floor(t)
    return {"sec": sec, "nsec": round((t - sec) * 1e9)}


def write_recording(path, heading):
    # Feet in the heading frame (ahead, left); FL and BR step together, then FR and BL.
    feet = {"FL": (0.2, 0.1), "FR": (0.2, -0.1), "BL": (-0.2, 0.1), "BR": (-0.2, -0.1)}
    first_pair = {"FL", "BR"}
    c, s = math.cos(heading), math.sin(heading)
    quat = {"x": 0.0, "y": 0.0, "z": math.sin(heading / 2), "w": math.cos(heading / 2)}
    with open(path, "wb") as f:
        w = Writer(f)
        w.start()
        schema = w.register_schema(name="json", encoding="jsonschema", data=b"{}")
        ch = {t: w.register_channel(topic=t, message_encoding="json", schema_id=schema)
              for t in ["/tf", "/contacts", "/metrics"]}
        for k in range(STEPS):
            t = k * DT
            ns = round(t * 1e9)
            ahead = SPEED * t
            base = {"x": c * ahead, "y": s * ahead, "z": 0.2}
            tf = {"transforms": [{"timestamp": stamp(t), "parent_frame_id": "world", "child_frame_id": "base",
                                  "translation": base, "rotation": quat}]}
            first_down = (t % PERIOD) < PERIOD / 2
            arrows = []
            for name, (fa, fl) in feet.items():
                if (name in first_pair) == first_down:
                    p = {"x": base["x"] + c * fa - s * fl, "y": base["y"] + s * fa + c * fl, "z": 0.0}
                    arrows.append({"pose": {"position": p, "orientation": quat}, "shaft_length": 0.1})
            contacts = {"deletions": [], "entities": [{"timestamp": stamp(t), "id": "contact_forces", "arrows": arrows}]}
            metrics = {"timestamp": stamp(t), "reward": 0.01, "forward_velocity": SPEED,
                       "commanded_speed": SPEED, "gait_rate": 1.0}
            for topic, msg in [("/tf", tf), ("/contacts", contacts), ("/metrics", metrics)]:
                w.add_message(channel_id=ch[topic], log_time=ns, publish_time=ns, data=json.dumps(msg).encode())
        w.finish()


@pytest.mark.parametrize("heading_deg", [0.0, 90.0])
def test_the_gait_tool_reads_a_known_trot(tmp_path, heading_deg):
    path = tmp_path / "trot.mcap"
    write_recording(path, math.radians(heading_deg))
    tool = load_tool()
    g = tool.summarize(*tool.read(path), start=1.0)
    assert g["steps"] == STEPS
    assert g["return"] == pytest.approx(0.01 * STEPS)
    assert g["yaw_at_end_deg"] == pytest.approx(heading_deg)
    # The steady speed is along world x, the axis the Minitaur's reward counts.
    assert g["steady_speed_x"] == pytest.approx(SPEED * math.cos(math.radians(heading_deg)), abs=1e-9)
    assert len(g["seconds"]) == 10
    for r in g["seconds"]:
        assert r["forward_velocity"] == pytest.approx(SPEED)
        assert r["height"] == pytest.approx(0.2)
        assert r["commanded_speed"] == pytest.approx(SPEED) and r["gait_rate"] == pytest.approx(1.0)
    # Two patterns, half the steps each, named in the heading frame.
    assert sorted(p for p, _ in g["patterns"]) == ["BLFR", "BRFL"]
    assert all(share == pytest.approx(0.5) for _, share in g["patterns"])
    # Two touchdowns a second per foot; over 9 s the first (at the window's start) is not seen.
    for foot, rate in g["touchdowns_per_second"].items():
        assert rate == pytest.approx(2.0, abs=0.15), foot
    with pytest.raises(ValueError, match="ends before"):
        tool.summarize(*tool.read(path), start=20.0)
