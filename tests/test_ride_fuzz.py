"""Schema-driven fuzzing of the ride service's HTTP API (schemathesis over ``/openapi.json``): every operation,
with no credential, an operator's and a device's (on one of its open rides half the time), answers below 500 and
refuses in one line; then the store still reads."""

import pytest

schemathesis = pytest.importorskip("schemathesis")
pytest.importorskip("fastapi")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from service_fixtures import model, raw  # noqa: E402,F401
from spotfree.ride.api import create_app  # noqa: E402
from spotfree.ride.service import RideService  # noqa: E402
from spotfree.ride.store import RideStore  # noqa: E402


@pytest.fixture(scope="module")
def world(tmp_path_factory, model):
    """The app over a fresh store, its operator token, a device token and a function giving that device's open
    ride."""
    service = RideService(model, RideStore(tmp_path_factory.mktemp("fuzz") / "rides.db", synchronous="normal"))
    operator = service.new_operator_token()
    _, device = service.register_device("fuzz")

    def open_ride() -> str:  # the device's open ride (a new one once a fuzzed call has ended it)
        return next(iter(service.open_rides()), None) or service.start_ride(device, "v", "r")
    yield create_app(service), operator, device, open_ride
    service.close()


@pytest.fixture(scope="module")
def operations(world):
    api = schemathesis.openapi.from_asgi("/openapi.json", world[0])
    return {result.ok().label: result.ok() for result in api.get_all_operations()}


OPERATIONS = ["POST /api/devices", "POST /api/enrolments", "POST /api/rides", "POST /api/rides/{ride_id}/samples",
              "POST /api/rides/{ride_id}/destination", "POST /api/rides/{ride_id}/end", "GET /api/rides",
              "GET /api/rides/{ride_id}", "GET /api/model", "GET /api/health", "POST /push"]


def test_the_schema_lists_every_operation(operations):
    assert sorted(operations) == sorted(OPERATIONS)


@pytest.mark.parametrize("label", OPERATIONS)
def test_no_input_gives_a_server_error(operations, world, label):
    _, operator, device, open_ride = world

    @settings(max_examples=60, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
    @given(operations[label].as_strategy(), st.sampled_from(["device", "operator", "none"]), st.booleans())
    def call(case, who, own_ride):
        credential = {"none": None, "operator": operator, "device": device}[who]
        if not own_ride and "ride_id" in (case.path_parameters or {}):
            case.path_parameters["ride_id"] = open_ride()
        headers = {"Authorization": f"Bearer {credential}"} if credential else {}
        response = case.call(headers=headers)
        assert response.status_code < 500, (case.method, case.path, case.body, response.text[:300])
        if response.status_code >= 400:
            detail = response.json().get("detail")
            assert isinstance(detail, str) and "\n" not in detail and len(detail) < 1000, detail
    call()


_JSON_VALUE = st.one_of(st.none(), st.booleans(), st.integers(-10**6, 10**6), st.floats(allow_nan=False),
                        st.text(max_size=5), st.lists(st.floats(), max_size=2))


@settings(max_examples=300, deadline=None, derandomize=True, database=None)
@given(st.dictionaries(st.sampled_from(["time", "ax", "ay", "az", "gx", "gy", "gz", "lat", "lon", "speed", "x"]),
                       st.lists(_JSON_VALUE, min_size=0, max_size=6), min_size=0, max_size=11),
       st.one_of(st.none(), st.floats(0, 1e6)))
def test_a_batch_is_checked_or_refused_in_one_line(columns, last_time):
    """Any JSON-shaped batch: either it passes and every value is within the limits, or InputError says why."""
    from spotfree import limits
    from spotfree.errors import InputError
    from spotfree.ride.validation import sample_batch

    try:
        table = sample_batch(columns, last_time, "fuzz")
    except InputError as exc:
        assert "\n" not in str(exc)
        return
    assert (table[:, 0] >= 0).all() and (table[:, 0] <= limits.MAX_RIDE_SECONDS).all()
    assert (abs(table[:, 1:4]) <= limits.MAX_ACCELERATION).all() and (abs(table[:, 4:7]) <= limits.MAX_ROTATION).all()
    assert all(type(v) in (int, float) or v is None for values in columns.values() for v in values)
