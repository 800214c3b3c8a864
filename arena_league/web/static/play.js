/*
 * Arena league play page: a person plays a game against the base population over a WebSocket.
 * Plain JavaScript, no build step; frames are drawn with the replay player's painter on a canvas
 * it sizes (window.ArenaReplay.paint and sizeCanvas, replay.js); window.Arena (app.js) builds
 * elements.
 *
 * The server's messages (arena_league.league.live): hello, match, frame, refused, end, error.
 * The page sends {"type": "next"} to start a match, {"type": "act", "text": ...} for a key or a
 * typed move, {"type": "act", "point": [x, y]} for a click on the view (world units), and
 * {"type": "resign"}.
 *
 * Contract for tests (on #play): data-state is "idle", "connecting", "playing" (the server steps
 * on its own), "your-move" (it waits for you), "ended" (a match ended; data-outcome is win, loss
 * or draw) or "error"; data-step is the step drawn; data-matches counts the matches ended;
 * data-bounds is the view's world rectangle [xmin, ymin, xmax, ymax] (JSON); data-you is "x,y",
 * where the label of your seat is drawn (absent when your seat has no body on the view).
 * Elements carry data-role: view (the canvas), seats, events, hint, outcome, reason, scores,
 * placement, next, resign, message (refusals and errors).
 */
(function () {
  "use strict";

  var root = document.getElementById("play");
  if (!root) return;
  var game = root.getAttribute("data-game");
  var el = window.Arena.el;
  var LIMITS = { least: 240, share: 0.72, lowest: 160 }; // the canvas' height: see ArenaReplay.sizeCanvas

  function part(role) { return root.querySelector('[data-role="' + role + '"]'); }

  var canvas = part("view");
  var socket = null;
  var controls = null;
  var bounds = [-1, -1, 1, 1];
  var shapes = [];
  var view = null;
  var size = null; // the canvas' CSS size and device pixel ratio, from sizeCanvas
  var held = []; // keys held, oldest first: their answers
  var sent = null; // the answer the held keys last sent
  var matches = 0;

  function setState(state) { root.setAttribute("data-state", state); }

  function say(text, kind) {
    var message = part("message");
    message.textContent = text || "";
    message.className = "play-message" + (kind ? " " + kind : "");
  }

  function send(message) {
    if (socket && socket.readyState === WebSocket.OPEN) socket.send(JSON.stringify(message));
  }

  // --- connection -----------------------------------------------------------------------------
  function connect(guest) {
    var scheme = location.protocol === "https:" ? "wss:" : "ws:";
    // a signed-in browser's socket carries the session's CSRF token (the cookie alone is not enough)
    var query = [guest ? "guest=" + encodeURIComponent(guest) : "",
                 window.Arena.csrfToken() ? "csrf=" + encodeURIComponent(window.Arena.csrfToken()) : ""].filter(Boolean);
    var url = scheme + "//" + location.host + "/ws/play/" + encodeURIComponent(game) +
      (query.length ? "?" + query.join("&") : "");
    setState("connecting");
    say("Connecting… (the first game of a league imports its base population, a few seconds)");
    socket = new WebSocket(url);
    socket.onmessage = function (event) {
      var message;
      try { message = JSON.parse(event.data); } catch (e) { return; }
      var handler = HANDLERS[message.type];
      if (handler) handler(message);
    };
    socket.onclose = function (event) {
      if (root.getAttribute("data-state") !== "error") {
        setState("error");
        say(event.reason ? "Closed: " + event.reason : "The connection closed; reload the page to play again.",
            "error");
      }
    };
  }

  var HANDLERS = {
    hello: function (message) {
      part("start-form").hidden = true;
      part("layout").hidden = false;
      say("You are " + message.agent + ". " + message.base + " has " + message.base_size + " agents, rated " +
          Math.round(message.ratings[0]) + " to " + Math.round(message.ratings[1]) + "; you start with the weakest.");
      showPlacement(message.placement);
      send({ type: "next" });
    },
    match: function (message) {
      controls = message.controls || { input: "text" };
      bounds = message.bounds;
      root.setAttribute("data-bounds", JSON.stringify(bounds));
      held = [];
      sent = null;
      part("result").hidden = true;
      part("resign").hidden = false;
      if (message.half !== 1) part("events").textContent = "";
      part("max-steps").textContent = message.max_steps;
      var half = message.half === null || message.half === undefined ? "" :
        (message.half === 0 ? " in the first half of a pair (then the other team, from the same start)"
                            : " in the second half of the pair");
      part("banner").textContent = "Match " + message.number + ": you play team " + message.team + half +
        " against " + message.opponent + " (rating " + Math.round(message.opponent_rating) + ", " + message.rung +
        " from the bottom).";
      showSeats(message.seats);
      part("hint").textContent = controls.hint || "";
      part("text-form").hidden = controls.input !== "text";
      canvas.classList.toggle("clickable", controls.input === "cells");
      setState("playing");
      root.removeAttribute("data-outcome");
      say("");
      resize();
      canvas.focus();
    },
    frame: function (message) {
      shapes = message.shapes || [];
      root.setAttribute("data-step", message.step);
      var you = shapes.filter(function (shape) { return shape.kind === "text" && shape.text === "you"; })[0];
      if (you) {
        root.setAttribute("data-you", you.x + "," + you.y);
      } else {
        root.removeAttribute("data-you");
      }
      part("step").textContent = message.step;
      (message.events || []).forEach(function (text) { addEvent(message.step, text); });
      setState(message.waiting ? "your-move" : "playing");
      draw();
    },
    refused: function (message) { say(message.reason, "refused"); },
    end: function (message) {
      matches += 1;
      root.setAttribute("data-matches", matches);
      root.setAttribute("data-outcome", message.outcome);
      setState("ended");
      var words = { win: "You won", loss: "You lost", draw: "A draw" };
      part("outcome").textContent = (words[message.outcome] || message.outcome) + " against " + message.opponent + ".";
      part("reason").textContent = "Why it ended: " + message.reason + ".";
      part("scores").textContent = "Scores: team 0 " + message.scores[0] + ", team 1 " + message.scores[1] +
        " (you were team " + message.team + "), after " + message.steps + " steps" +
        (message.match_id ? "; stored as match " + message.match_id + "." : ".");
      addEvent(message.steps, message.reason);
      part("result").hidden = false;
      part("resign").hidden = true;
      showPlacement(message.placement);
      part("next").focus();
    },
    error: function (message) {
      setState("error");
      say(message.detail, "error");
    }
  };

  // --- panels ---------------------------------------------------------------------------------
  function showSeats(seats) {
    var list = part("seats");
    list.textContent = "";
    seats.forEach(function (seat) {
      var swatch = el("span", { "class": "swatch" });
      swatch.style.background = seat.color;
      var role = seat.role === "you" ? "you (" + seat.agent + ")" : seat.role + ": " + seat.agent;
      list.appendChild(el("li", { "data-seat": seat.seat, "data-seat-role": seat.role },
        [swatch, el("strong", {}, seat.label), " team " + seat.team + ", " + role]));
    });
  }

  function addEvent(step, text) {
    var list = part("events");
    var item = document.createElement("li");
    item.textContent = "step " + step + ": " + text;
    list.insertBefore(item, list.firstChild);
  }

  function showPlacement(placement) {
    var target = part("placement");
    if (!placement || placement.rating === null || placement.rating === undefined) {
      target.textContent = "No match yet.";
      return;
    }
    target.textContent = "Rating " + Math.round(placement.rating) + " (95% " + Math.round(placement.lower) + " to " +
      Math.round(placement.upper) + "), rank " + placement.rank + " of " + (placement.base_size + 1) + " (between " +
      placement.rank_lower + " and " + placement.rank_upper + "), above " + Math.round(placement.percentile) +
      "% of " + placement.base + ", from " + placement.total_matches + " match(es).";
  }

  // --- drawing --------------------------------------------------------------------------------
  function resize() {
    if (!window.ArenaReplay) return;
    var width = Math.max(200, Math.floor(canvas.parentNode.clientWidth));
    size = window.ArenaReplay.sizeCanvas(canvas, bounds, width, LIMITS);
    draw(); // the bounds or the shapes may be new even when the size is not
  }

  function draw() {
    var context = canvas.getContext && canvas.getContext("2d");
    if (!context || !window.ArenaReplay || !size) return;
    view = window.ArenaReplay.paint(context, size.dpr, size.width, size.height, bounds, shapes);
  }

  window.addEventListener("resize", resize);

  // --- input ----------------------------------------------------------------------------------
  function answerOfHeld() {
    if (!held.length) return controls.release;
    var newest = held[held.length - 1];
    if (!controls.combine) return newest;
    var order = controls.combine;
    var joined = held.slice().sort(function (a, b) { return order.indexOf(a) - order.indexOf(b); })
      .filter(function (answer, i, all) { return all.indexOf(answer) === i; }).join("");
    if (joined.length === 1 || (controls.accepts || []).indexOf(joined) >= 0) return joined;
    return newest;
  }

  function playing() {
    var state = root.getAttribute("data-state");
    return state === "playing" || state === "your-move";
  }

  function typing(event) {
    var tag = event.target && event.target.tagName ? event.target.tagName.toLowerCase() : "";
    return tag === "input" || tag === "textarea" || tag === "select";
  }

  document.addEventListener("keydown", function (event) {
    if (!controls || controls.input !== "keys" || !playing() || typing(event)) return;
    if (event.altKey || event.ctrlKey || event.metaKey) return;
    var answer = (controls.keys || {})[event.key];
    if (answer === undefined) return;
    event.preventDefault(); // arrows would scroll the page
    if (event.repeat) return;
    held = held.filter(function (a) { return a !== answer; });
    held.push(answer);
    var now = answerOfHeld();
    if (now !== sent || !controls.pace) {
      sent = now;
      send({ type: "act", text: now });
    }
  });

  document.addEventListener("keyup", function (event) {
    if (!controls || controls.input !== "keys" || !playing()) return;
    var answer = (controls.keys || {})[event.key];
    if (answer === undefined) return;
    held = held.filter(function (a) { return a !== answer; });
    var now = answerOfHeld();
    if (now !== null && now !== undefined && now !== sent) {
      sent = now;
      send({ type: "act", text: now });
    }
  });

  canvas.addEventListener("click", function (event) {
    if (!controls || controls.input !== "cells" || !view) return;
    if (root.getAttribute("data-state") !== "your-move") {
      say("Wait for your move.", "refused");
      return;
    }
    var box = canvas.getBoundingClientRect();
    var point = view.toWorld(event.clientX - box.left, event.clientY - box.top);
    say("");
    send({ type: "act", point: point });
  });

  part("text-form").addEventListener("submit", function (event) {
    event.preventDefault();
    var input = part("text");
    send({ type: "act", text: input.value });
    input.value = "";
  });

  part("start-form").addEventListener("submit", function (event) {
    event.preventDefault();
    var guest = part("guest");
    connect(guest ? guest.value.trim() : null);
  });

  part("next").addEventListener("click", function () { send({ type: "next" }); });
  part("resign").addEventListener("click", function () { send({ type: "resign" }); });
})();
