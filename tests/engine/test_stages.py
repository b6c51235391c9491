"""engine.experiments.common.Stages: the progress bar of a test ends at 100 % when the test
finished before its upper bound of steps, and keeps its share when it stopped on an error."""
from engine.experiments.common import Stages


class _Bar:
    def __init__(self, n, total):
        self.n, self.total = n, total

    def refresh(self):
        pass

    def close(self):
        self.closed = True


def _stages(n, total, interrupted=False):
    st = Stages.__new__(Stages)          # the bar's bookkeeping only, no model
    st.bar, st.interrupted = _Bar(n, total), interrupted
    return st


def test_a_finished_test_ends_its_bar_at_its_step_count():
    st = _stages(913, 4463)
    st.close()
    assert st.bar.total == 913 and st.bar.closed


def test_an_error_or_ctrl_c_keeps_the_bar_where_it_stopped():
    st = _stages(500, 4463)
    try:
        try:
            raise RuntimeError("the sample came apart")
        finally:
            st.close()
    except RuntimeError:
        pass
    assert st.bar.total == 4463
    st = _stages(500, 4463, interrupted=True)
    st.close()
    assert st.bar.total == 4463


def test_the_tests_share_one_default_wire_law_and_refuse_a_contact_law(tmp_path):
    """None gives the paper's ElasticWire(k = 1 N); a contact law is refused by every test
    before any sample is built, naming wire_law."""
    import pytest

    from engine import laws
    from engine.experiments import box_triaxial, cylinder_triaxial, slope_deposit
    from engine.experiments.common import DEFAULT_WIRE_STIFFNESS, wire_law_or_default

    assert wire_law_or_default(None) == laws.ElasticWire(stiffness=DEFAULT_WIRE_STIFFNESS)
    assert DEFAULT_WIRE_STIFFNESS == 1.0
    rigid = laws.RigidWire()
    assert wire_law_or_default(rigid) is rigid
    for test in (cylinder_triaxial, box_triaxial, slope_deposit):
        with pytest.raises(ValueError, match=r"wire_law must be a wire law .*Coulomb"):
            test(0.05, wire_law=laws.Coulomb(mu=0.3), progress=False,
                 history=str(tmp_path / "x.h5"))
