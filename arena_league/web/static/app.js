// arena-league pages: sortable tables and a job's live progress. Plain JavaScript, no build step;
// every page works without it (the server sorts with ?sort=, a job page refreshes itself).
(function () {
  "use strict";

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
    var id = box.getAttribute("data-job");
    var state = box.querySelector('[data-role="state"]');
    var bar = box.querySelector('[data-role="progress"]');
    var count = box.querySelector('[data-role="count"]');
    var result = box.querySelector('[data-role="result"]');
    var source = new EventSource("/api/jobs/" + id + "/events");
    function show(view) {
      box.setAttribute("data-state", view.state);
      state.textContent = view.state;
      if (view.progress) {
        bar.max = view.progress.total || 1;
        bar.value = view.progress.done || 0;
        count.textContent = view.progress.done + " / " + view.progress.total;
      }
      if (view.finished) {
        if (view.result) {
          var pre = document.createElement("pre");
          pre.className = "log";
          pre.textContent = JSON.stringify(view.result, null, 2);
          result.replaceChildren(pre);
        }
        if (view.error) {
          var error = document.createElement("p");
          error.className = "reason";
          error.setAttribute("data-role", "error");
          error.textContent = view.error;
          result.replaceChildren(error);
        }
        if (view.state === "done" || view.state === "failed") bar.value = bar.max;
      }
    }
    source.addEventListener("progress", function (event) { show(JSON.parse(event.data)); });
    source.addEventListener("done", function (event) { show(JSON.parse(event.data)); source.close(); });
    source.onerror = function () { source.close(); setTimeout(function () { window.location.reload(); }, 2000); };
  }

  document.addEventListener("DOMContentLoaded", function () {
    Array.prototype.forEach.call(document.querySelectorAll("table.sortable"), makeSortable);
    var job = document.getElementById("job");
    if (job && ["done", "failed", "cancelled"].indexOf(job.getAttribute("data-state")) < 0) followJob(job);
  });
})();
