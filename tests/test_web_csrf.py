"""Cross-site request forgery against a real ``arena-league serve``: a write made with the sign-in
cookie must come from the league's own pages (Origin, Sec-Fetch-Site) and carry the session's CSRF
token; signing in needs the sign-in form's own token; the play socket checks the same; every
response carries the security headers.

The attacks run twice: over plain HTTP (httpx, the websockets client) with the headers a browser
would send, and in Debian's Chromium (Playwright) from an attacker's page served on another port
of the same host (same-site, so the cookie's SameSite=Strict lets the cookie through) and on
``localhost`` (another site), with the victim signed in on the league's origin.
"""

from __future__ import annotations

import base64
import functools
import http.server
import threading
from collections.abc import Iterator
from pathlib import Path

import hostile_agents as hostile
import httpx
import pytest
from web_helpers import Server, free_port, running_server
from websockets.exceptions import ConnectionClosed
from websockets.sync.client import connect

from arena_league.web.auth import COOKIE
from arena_league.web.csrf import SIGNIN_COOKIE, session_token

GAME = "GoBang-2T1P-v1"
HEADERS = ("content-security-policy", "x-content-type-options", "x-frame-options", "referrer-policy")


@pytest.fixture(scope="module")
def server(tmp_path_factory) -> Iterator[Server]:
    with running_server(tmp_path_factory.mktemp("csrf") / "home") as running:
        yield running


@pytest.fixture(scope="module")
def alice(server) -> str:
    return server.token("alice")


def cookie_client(server: Server, token: str, **headers: str) -> httpx.Client:
    """A client that, like a signed-in browser, presents the token only as the sign-in cookie."""
    return httpx.Client(base_url=server.url, cookies={COOKIE: token}, headers=headers, timeout=60)


def onnx_bytes(tmp_path: Path, seed: int) -> bytes:
    return hostile.save(hostile.plain(GAME, seed=seed), tmp_path / f"agent-{seed}.onnx").read_bytes()


def test_a_cookie_write_without_the_csrf_token_or_from_another_origin_is_refused(server, alice):
    other = f"http://127.0.0.1:{free_port()}"
    tree = {"game": "Crossroads-2T2P-v1", "spec": {}}
    with cookie_client(server, alice) as client:
        bare = client.post("/api/trees/check", json=tree)
        assert bare.status_code == 403 and "CSRF token" in bare.json()["detail"]
        assert "reload the page" in bare.json()["detail"] and "\n" not in bare.json()["detail"]
        wrong = client.post("/api/trees/check", json=tree, headers={"X-CSRF-Token": session_token("al_someone")})
        assert wrong.status_code == 403
        assert client.delete("/api/trees/1").status_code == 403
        assert client.post(f"/agents/{alice}/rank").status_code == 403  # a page's form, without its field
        token = session_token(alice)
        foreign = client.post("/api/trees/check", json=tree, headers={"X-CSRF-Token": token, "Origin": other})
        assert foreign.status_code == 403 and other in foreign.json()["detail"]
        same_site = client.post("/api/trees/check", json=tree,
                                headers={"X-CSRF-Token": token, "Sec-Fetch-Site": "same-site"})
        assert same_site.status_code == 403 and "Sec-Fetch-Site: same-site" in same_site.json()["detail"]
        # from the league's own page: the header, or a form's first field
        own = {"X-CSRF-Token": token, "Origin": server.url, "Sec-Fetch-Site": "same-origin"}
        assert client.post("/api/trees/check", json=tree, headers=own).status_code == 200
        form = client.post("/agents/nobody/rank", data={"csrf_token": token}, headers={"Origin": server.url})
        assert form.status_code == 404  # past the guard: the route says there is no such agent
        last = client.post("/agents/nobody/rank", data={"x": "1", "csrf_token": token})
        assert last.status_code == 403  # the token is the form's first field, read before the rest


def test_a_bearer_write_needs_no_csrf_token(server, alice):
    with server.client(alice) as client:
        checked = client.post("/api/trees/check", json={"game": "Crossroads-2T2P-v1", "spec": {}})
        assert checked.status_code == 200
        # a page of another origin cannot send this header (no CORS), so the Origin does not matter
        elsewhere = client.post("/api/trees/check", json={"game": "Crossroads-2T2P-v1", "spec": {}},
                                headers={"Origin": "http://127.0.0.1:1"})
        assert elsewhere.status_code == 200


def test_an_upload_form_without_the_token_is_refused_and_nothing_is_registered(server, alice, tmp_path):
    files = {"file": ("model.onnx", onnx_bytes(tmp_path, 3))}
    with cookie_client(server, alice) as client:
        refused = client.post("/submit", data={"game": GAME, "name": "forged-upload"}, files=files,
                              headers={"Origin": server.url})
        assert refused.status_code == 403
        assert client.get("/api/agents/forged-upload").status_code == 404
        taken = client.post("/submit", data={"csrf_token": session_token(alice), "game": GAME, "name": "own-upload"},
                            files=files, headers={"Origin": server.url})
        assert taken.status_code == 303 and taken.headers["location"].startswith("/jobs/")
        assert client.get("/api/agents/own-upload").json()["owner"] == "alice"


def test_signing_in_and_out_needs_the_forms_own_token(server, alice):
    mallory = server.token("mallory")
    with httpx.Client(base_url=server.url, timeout=60) as client:
        forged = client.post("/signin", data={"token": mallory, "next": "/"})
        assert forged.status_code == 403 and COOKIE not in forged.cookies
        form = client.get("/signin")
        field = form.cookies[SIGNIN_COOKIE]
        assert f'name="csrf_token" value="{field}"' in form.text
        guessed = client.post("/signin", data={"csrf_token": "guessed", "token": mallory})
        assert guessed.status_code == 403 and COOKIE not in guessed.cookies
        foreign = client.post("/signin", data={"csrf_token": field, "token": mallory},
                              headers={"Origin": "http://localhost:1", "Sec-Fetch-Site": "cross-site"})
        assert foreign.status_code == 403 and COOKIE not in foreign.cookies
        signed = client.post("/signin", data={"csrf_token": field, "token": alice}, headers={"Origin": server.url})
        assert signed.status_code == 303 and client.cookies[COOKIE] == alice
        assert client.post("/signout").status_code == 403  # signed in: signing out is a write like any
        out = client.post("/signout", data={"csrf_token": session_token(alice)})
        assert out.status_code == 303 and COOKIE not in client.cookies


def test_every_response_carries_the_security_headers(server, alice):
    with httpx.Client(base_url=server.url, timeout=60) as client:
        answers = [client.get("/"), client.get(f"/games/{GAME}"), client.get("/api/games"), client.get("/signin"),
                   client.get("/static/app.js"), client.get("/nowhere"), client.get("/api/agents/nobody"),
                   client.post("/api/agents/x/rank"), client.get("/openapi.json"), client.get("/docs")]
        client.cookies.set(COOKIE, alice)
        answers.append(client.post("/api/trees/check", json={}))
    assert [a.status_code for a in answers] == [200, 200, 200, 200, 200, 404, 404, 401, 200, 200, 403]
    for answer in answers:
        assert all(name in answer.headers for name in HEADERS), answer.url
        policy = answer.headers["content-security-policy"]
        assert "frame-ancestors 'none'" in policy and answer.headers["x-frame-options"] == "DENY"
        assert answer.headers["x-content-type-options"] == "nosniff"
        assert answer.headers["referrer-policy"] == "same-origin"
        if answer.url.path != "/docs":  # the API explorer is an inline script of its own
            assert "script-src 'self';" in policy and "unsafe-inline" not in policy.split("script-src")[1].split(";")[0]


def _socket_refusal(url: str, **headers: str) -> tuple[int | None, str]:
    """The close code and reason of a play socket opened with these handshake headers (None: it
    stayed open past its first message)."""
    with connect(url, additional_headers=headers, open_timeout=30) as socket:
        try:
            socket.recv(timeout=30)
            socket.recv(timeout=30)
        except ConnectionClosed as closed:
            return closed.rcvd.code if closed.rcvd else None, closed.rcvd.reason if closed.rcvd else ""
        except TimeoutError:
            pass
    return None, ""


def test_a_play_socket_from_another_origin_or_without_the_token_is_refused(server, alice):
    base = server.url.replace("http://", "ws://") + f"/ws/play/{GAME}"
    other = f"http://127.0.0.1:{free_port()}"
    code, reason = _socket_refusal(base, Cookie=f"{COOKIE}={alice}", Origin=other)
    assert code == 1008 and other in reason
    code, reason = _socket_refusal(base + "?guest=eve", Origin=other)  # a guest's socket from there too
    assert code == 1008
    code, reason = _socket_refusal(base, Cookie=f"{COOKIE}={alice}", Origin=server.url)
    assert code == 1008 and "CSRF token" in reason
    # the play page's own socket: past the guard (it plays, or says the base population is on its way)
    code, reason = _socket_refusal(f"{base}?csrf={session_token(alice)}", Cookie=f"{COOKIE}={alice}",
                                   Origin=server.url)
    assert code != 1008


# --- in the browser -----------------------------------------------------------------------------

class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args: object) -> None:
        pass


@pytest.fixture(scope="module")
def attacker(tmp_path_factory) -> Iterator[tuple[Path, int]]:
    """A folder served over HTTP on another port of the same host: the attacker's site."""
    folder = tmp_path_factory.mktemp("attacker")
    site = http.server.ThreadingHTTPServer(("127.0.0.1", 0), functools.partial(_Quiet, directory=str(folder)))
    thread = threading.Thread(target=site.serve_forever, daemon=True)
    thread.start()
    try:
        yield folder, site.server_address[1]
    finally:
        site.shutdown()
        site.server_close()


def _signed_in_browser(server: Server, browser, token: str):
    context = browser.new_context()
    page = context.new_page()
    page.set_default_timeout(60_000)
    page.goto(f"{server.url}/signin")
    page.fill('input[name="token"]', token)
    page.click('form[action="/signin"] button[type="submit"]')
    page.wait_for_selector('[data-role="signed-in"]')
    return context, page


@pytest.fixture(scope="module")
def browser():
    from browser_helpers import chromium, playwright_or_skip

    with chromium(playwright_or_skip()) as launched:
        yield launched


@pytest.mark.slow
def test_a_page_on_another_port_cannot_rank_upload_or_play_as_the_signed_in_user(server, alice, attacker, browser,
                                                                                 tmp_path):
    folder, port = attacker
    with server.client(alice) as client:  # alice's active agent, which the attacker would rank
        queued = client.post("/api/agents", data={"game": GAME, "name": "victim"},
                             files={"file": ("model.onnx", onnx_bytes(tmp_path, 5))}).json()
    assert server.wait_job(queued["job"])["result"]["status"] == "active"
    league = server.url
    model = base64.b64encode(onnx_bytes(tmp_path, 7)).decode()
    (folder / "rank.html").write_text(
        f'<form method="post" action="{league}/agents/victim/rank"></form>'
        '<script>document.forms[0].submit()</script>')
    (folder / "upload.html").write_text(
        f'<form method="post" action="{league}/submit" enctype="multipart/form-data">'
        f'<input name="game" value="{GAME}"><input name="name" value="planted"><input type="file" name="file"></form>'
        f'<script>const bytes = Uint8Array.from(atob("{model}"), c => c.charCodeAt(0));'
        'const files = new DataTransfer(); files.items.add(new File([bytes], "model.onnx"));'
        'document.querySelector("input[type=file]").files = files.files; document.forms[0].submit()</script>')
    (folder / "socket.html").write_text(
        f'<script>window.seen = []; const s = new WebSocket("{league.replace("http://", "ws://")}/ws/play/{GAME}");'
        's.onmessage = e => window.seen.push(JSON.parse(e.data));'
        's.onclose = e => { window.ended = {code: e.code, reason: e.reason}; };</script>')
    context, page = _signed_in_browser(server, browser, alice)
    try:
        with page.expect_navigation(url=f"{league}/**") as ranked:
            page.goto(f"http://127.0.0.1:{port}/rank.html")
        assert ranked.value.status == 403 and "another origin of this site" in page.inner_text("main")
        with page.expect_navigation(url=f"{league}/**") as uploaded:
            page.goto(f"http://127.0.0.1:{port}/upload.html")
        assert uploaded.value.status == 403
        page.goto(f"http://127.0.0.1:{port}/socket.html")
        page.wait_for_function("() => window.ended !== undefined")
        ended, seen = page.evaluate("window.ended"), page.evaluate("window.seen")
        assert ended["code"] == 1008 and f"127.0.0.1:{port}" in ended["reason"]
        assert [message["type"] for message in seen] == ["error"]  # no hello: nothing played as alice
    finally:
        context.close()
    with server.client() as client:
        assert client.get("/api/agents/planted").status_code == 404
        assert client.get(f"/api/jobs/{queued['job'] + 1}").status_code == 404  # no rank, no validation queued


@pytest.mark.slow
def test_a_cross_site_form_cannot_sign_the_browser_in(server, alice, attacker, browser):
    folder, port = attacker
    mallory = server.token("mallory")
    (folder / "login.html").write_text(
        f'<form method="post" action="{server.url}/signin"><input name="csrf_token" value="guessed">'
        f'<input name="token" value="{mallory}"><input name="next" value="/"></form>'
        '<script>document.forms[0].submit()</script>')
    context = browser.new_context()
    page = context.new_page()
    page.set_default_timeout(60_000)
    try:
        page.goto(f"{server.url}/signin")  # the victim has the sign-in form's cookie: still not enough
        # localhost and 127.0.0.1 are different sites: this is a cross-site form
        with page.expect_navigation(url=f"{server.url}/**") as posted:
            page.goto(f"http://localhost:{port}/login.html")
        assert posted.value.status == 403
        page.goto(f"{server.url}/")
        assert page.locator('[data-role="signed-in"]').count() == 0
        assert COOKIE not in {c["name"] for c in context.cookies()}
    finally:
        context.close()


@pytest.mark.slow
def test_the_main_pages_break_no_rule_of_the_content_security_policy(server, alice, browser, tmp_path):
    with server.client(alice) as client:
        tree = client.post("/api/trees", json={"name": "csp-tree", "game": "Crossroads-2T2P-v1", "spec": {}})
        client.post("/api/agents", data={"game": GAME, "name": "csp-agent"},
                    files={"file": ("model.onnx", onnx_bytes(tmp_path, 9))})
    context, page = _signed_in_browser(server, browser, alice)
    problems: list[str] = []
    page.on("console", lambda message: problems.append(message.text) if message.type == "error" else None)
    page.on("pageerror", lambda error: problems.append(str(error)))
    page.on("response", lambda answer: problems.append(f"{answer.status} {answer.url}")
            if answer.status == 403 else None)
    try:
        paths = ["/", f"/games/{GAME}", "/agents/csp-agent", "/trees/new", f"/play/{GAME}", "/submit", "/trees"]
        if tree.status_code == 201:
            paths.append(f"/trees/{tree.json()['id']}")
        for path in paths:
            page.goto(f"{server.url}{path}")
            page.wait_for_load_state("networkidle")
        page.context.clear_cookies()
        page.goto(f"{server.url}/signin")
        page.wait_for_load_state("networkidle")
    finally:
        context.close()
    csp = [p for p in problems if "Content Security Policy" in p or p.startswith("403 ")]
    assert csp == []
