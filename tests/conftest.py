import pytest


@pytest.fixture(params=[0.5, 1.0], ids=["theta0.5", "theta1"])
def theta(request):
    """Every physics test runs at both ends of the θ range [0.5, 1]."""
    return request.param
