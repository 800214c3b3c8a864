// arena-league pages: sortable tables and a job's live progress. Plain JavaScript, no build step;
// every page works without it (the server sorts with ?sort=, a job page refreshes itself).
// It loads first on every page and shares its helpers as window.Arena: el, request, messageOf,
// watchJob, csrfToken.
(function () {
  "use strict";

  /* An element: attributes (null, undefined and false left out, true as ""), then content, a
     string, a node or a list of them. */
  function el(tag, attributes, content) {
    var node = document.createElement(tag);
    Object.keys(attributes || {}).forEach(function (name) {
      var value = attributes[name];
      if (value === null || value === undefined || value === false) return;
      node.setAttribute(name, value === true ? "" : String(value));
    });
    if (content === undefined || content === null) return node;
    (Array.isArray(content) ? content : [content]).forEach(function (part) {
      if (part === null || part === undefined || part === false) return;
      node.appendChild(typeof part === "string" || typeof part === "number"
        ? document.createTextNode(String(part)) : part);
    });
    return node;
  }

  /* The server's one-line {"detail"} of an answer that is not ok (FastAPI's lists joined), or
     undefined when it sent none. */
  function detailOf(data) {
    var detail = data && data.detail;
    if (typeof detail === "string") return detail;
    if (Array.isArray(detail)) {
      return detail.map(function (item) {
        var where = Array.isArray(item.loc) ? item.loc.filter(function (part) { return part !== "body"; }).join(".") : "";
        return (where ? where + ": " : "") + (item.msg || JSON.stringify(item));
      }).join("; ");
    }
    if (detail !== undefined) return JSON.stringify(detail);
    return undefined;
  }

  /* The session's CSRF token the server put in the page ("" when not signed in): a write made
     with the sign-in cookie carries it, which a page of another site cannot read. */
  function csrfToken() {
    var meta = document.querySelector('meta[name="csrf-token"]');
    return meta ? meta.getAttribute("content") || "" : "";
  }

  /* A JSON request on this site with the sign-in cookie (and, writing, the CSRF token); resolves
     with the parsed body, rejects with an Error holding the server's one-line detail (error.detail:
     the detail alone, or the body's text when it has none; error.status, error.statusText). */
  function request(method, url, body) {
    var init = { method: method, credentials: "same-origin", headers: { Accept: "application/json" } };
    if (method !== "GET" && method !== "HEAD" && csrfToken()) init.headers["X-CSRF-Token"] = csrfToken();
    if (body !== undefined) {
      init.headers["Content-Type"] = "application/json";
      init.body = JSON.stringify(body);
    }
    return fetch(url, init).then(function (response) {
      return response.text().then(function (text) {
        var data = null;
        try { data = text ? JSON.parse(text) : null; } catch (ignored) { data = null; }
        if (!response.ok) {
          var detail = detailOf(data);
          var answered = "the server answered " + response.status + " " + response.statusText;
          var error = new Error(detail === undefined ? answered : detail);
          error.status = response.status;
          error.statusText = response.statusText;
          error.detail = detail !== undefined ? detail : text;
          throw error;
        }
        return data;
      });
    });
  }

  function messageOf(error) {
    return error && error.message ? error.message : String(error);
  }

  /* Follow the job id through its server-sent events (progress, then done, each the job's view);
     onView sees every view on the way. Resolves with the finished view. When the stream fails,
     one GET /api/jobs/ID decides: its view if the job has finished, else a rejection. */
  function watchJob(id, onView) {
    var url = "/api/jobs/" + encodeURIComponent(id);
    function seen(view) {
      if (onView) onView(view);
      return view;
    }
    function lastLook() {
      return request("GET", url).then(function (view) {
        seen(view);
        if (!view.finished) throw new Error("lost the progress of job " + id + " (it is " + view.state + ")");
        return view;
      });
    }
    if (!window.EventSource) return lastLook();
    return new Promise(function (resolve, reject) {
      var source = new EventSource(url + "/events");
      source.addEventListener("progress", function (event) { seen(JSON.parse(event.data)); });
      source.addEventListener("done", function (event) {
        source.close();
        resolve(seen(JSON.parse(event.data)));
      });
      source.onerror = function () {
        source.close();
        lastLook().then(resolve, reject);
      };
    });
  }

  window.Arena = { el: el, request: request, messageOf: messageOf, watchJob: watchJob, csrfToken: csrfToken };

  function cellValue(row, index, numeric) {
    var cell = row.cells[index];
    if (!cell) return numeric ? -Infinity : "";
    var raw = cell.getAttribute("data-value");
    if (raw === null) raw = cell.textContent.trim();
    if (!numeric) return raw.toLowerCase();
    var number = parseFloat(raw);
    return isNaN(number) ? -Infinity : number;
  }

  function makeSortable(table) {
    var headers = table.tHead ? table.tHead.rows[0].cells : [];
    Array.prototype.forEach.call(headers, function (th, index) {
      var kind = th.getAttribute("data-sort");
      if (!kind) return;
      th.addEventListener("click", function (event) {
        event.preventDefault();
        var numeric = kind === "num";
        var ascending = th.getAttribute("aria-sort") !== "ascending";
        Array.prototype.forEach.call(headers, function (other) { other.removeAttribute("aria-sort"); });
        th.setAttribute("aria-sort", ascending ? "ascending" : "descending");
        var body = table.tBodies[0];
        var rows = Array.prototype.slice.call(body.rows);
        rows.sort(function (a, b) {
          var x = cellValue(a, index, numeric), y = cellValue(b, index, numeric);
          var order = x < y ? -1 : x > y ? 1 : 0;
          return ascending ? order : -order;
        });
        rows.forEach(function (row) { body.appendChild(row); });
      });
    });
  }

  function followJob(box) {
    if (!window.EventSource) return;
    var state = box.querySelector('[data-role="state"]');
    var bar = box.querySelector('[data-role="progress"]');
    var count = box.querySelector('[data-role="count"]');
    var summary = box.querySelector('[data-role="summary"]');
    var links = box.querySelector('[data-role="links"]');
    var result = box.querySelector('[data-role="result"]');
    function show(view) {
      box.setAttribute("data-state", view.state);
      state.textContent = view.state;
      if (view.progress) {
        bar.max = view.progress.total || 1;
        bar.value = view.progress.done || 0;
        count.textContent = view.progress.label;
      }
      summary.textContent = view.summary;
      summary.className = view.state === "failed" ? "reason" : "summary";
      if (!view.finished) return;
      links.replaceChildren.apply(links, (view.links || []).map(function (link) {
        return el("li", {}, el("a", { href: link.href, "data-role": link.role || null }, link.text));
      }));
      if (view.result !== null && view.result !== undefined) {
        result.querySelector("pre").textContent = JSON.stringify(view.result, null, 2);
        result.hidden = false;
      }
    }
    watchJob(box.getAttribute("data-job"), show).catch(function () {
      setTimeout(function () { window.location.reload(); }, 2000);
    });
  }

  /* A page waiting for the import of its game's base population shows it once the job is done. */
  function followImport(notice) {
    watchJob(notice.getAttribute("data-job")).then(function () { window.location.reload(); }, function () {
      setTimeout(function () { window.location.reload(); }, 5000);
    });
  }

  document.addEventListener("DOMContentLoaded", function () {
    Array.prototype.forEach.call(document.querySelectorAll("table.sortable"), makeSortable);
    var job = document.getElementById("job");
    if (job && ["done", "failed", "cancelled"].indexOf(job.getAttribute("data-state")) < 0) followJob(job);
    var importing = document.getElementById("importing");
    if (importing && ["queued", "running"].indexOf(importing.getAttribute("data-state")) >= 0) followImport(importing);
  });
})();
