"""Property-based tests of the JSON API with schemathesis: requests generated from /openapi.json
(with and without a token) never make the server fail (no 5xx), and every documented answer
matches its schema. The server is real (uvicorn in a subprocess, a temporary league)."""

from __future__ import annotations

import pytest
import schemathesis
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from schemathesis.checks import not_a_server_error, response_schema_conformance
from web_helpers import running_server

pytestmark = pytest.mark.slow
#: Generated requests in all (over every operation), each sent without and with a token.
EXAMPLES = 150


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    with running_server(tmp_path_factory.mktemp("schema") / "home", workers=0) as running:
        yield running


def test_generated_requests_never_fail_the_server(server):
    token = server.token("fuzzer")
    schema = schemathesis.openapi.from_url(f"{server.url}/openapi.json")
    operations = [result.ok() for result in schema.get_all_operations()]
    assert len(operations) >= 15
    seen: set[str] = set()

    @given(case=st.sampled_from(operations).flatmap(lambda operation: operation.as_strategy()))
    @settings(max_examples=EXAMPLES, deadline=None, suppress_health_check=list(HealthCheck), database=None)
    def check(case) -> None:
        seen.add(f"{case.method} {case.path}")
        for headers in ({}, {"Authorization": f"Bearer {token}"}):
            case.call_and_validate(headers=headers, checks=[not_a_server_error, response_schema_conformance])

    check()
    assert len(seen) >= 10  # most operations were tried
