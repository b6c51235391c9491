"""engine.warm: the scenes that compile the kernels run stage by stage, side by side, and a
scene that fails is reported without stopping the others."""
import time

from engine import warm


def test_stages_run_in_order_and_a_failure_is_one_line(tmp_path, monkeypatch):
    def mark(name, pause=0.0):
        def scene():
            time.sleep(pause)
            (tmp_path / name).write_text(repr(time.time()))
        return scene

    def broken():
        raise ValueError("no such kernel\nsecond line")

    # (the pool forks: its processes see the patched tables)
    monkeypatch.setattr(warm, "SCENES", {"a": mark("a", 0.3), "b": broken, "c": mark("c")})
    monkeypatch.setattr(warm, "STAGES", (("a", "b"), ("c",)))
    out = warm.warm(jobs=2, quiet=True)
    assert out["b"] == "ValueError: no such kernel"
    assert isinstance(out["a"], float) and out["a"] >= 0.3
    assert float((tmp_path / "c").read_text()) > float((tmp_path / "a").read_text())


def test_every_scene_is_in_a_stage():
    staged = [n for stage in warm.STAGES for n in stage]
    assert sorted(staged) == sorted(warm.SCENES) and len(set(staged)) == len(staged)
