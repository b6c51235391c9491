import pytest

from engine import step

from tests.helpers import box_pile


@pytest.fixture(scope="session")
def pile_states():
    """A 300-grain pile (frictional grains, frictionless walls) while it lands (step 150)
    and at rest (step 700), stepped with the default solver options but tol 1e-6.
    Returns (model, {step: state}); tests copy the states before stepping them."""
    model, state, box, _ = box_pile(300, 12e-3, tol=1e-6, max_iter=2000)
    out = {}
    for k in range(1, 701):
        step(model, state)
        if k in (150, 700):
            out[k] = state.copy()
    return model, out
