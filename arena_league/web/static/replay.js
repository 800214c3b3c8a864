/*
 * Arena league replay player: plain JavaScript, no build step, no dependencies.
 *
 * Every element <div class="replay-player" data-src="URL"> on the page becomes a player of the
 * replay document served at URL (the JSON of arena_league.league.replay_document): a canvas
 * drawing the match from above, a caption naming each team's agents in the team colour, the
 * step counter, the events of the step, the outcome once the last frame shows, and controls.
 *
 * Contract for pages and browser tests (on the container):
 *   data-state    "loading", then "ready" or "error" (with a readable message inside)
 *   data-playing  "true" | "false"
 *   data-frame    index of the frame shown (0 .. frames - 1)
 * Controls carry data-role: play, back, forward, speed, seek; text: step, outcome, caption,
 * events; the canvas: view. Keys (focus inside a player, or anywhere on a page with one
 * player): space plays or pauses, left and right arrows step back and forward.
 * Speed 1x shows 10 frames per second; playback stops on the last frame.
 * Players added to the page later can be started with window.ArenaReplay.mount(element), and
 * stopped with window.ArenaReplay.unmount(element) before the element goes.
 * Other pages draw frames with the same painter: window.ArenaReplay.paint(context, dpr, width,
 * height, bounds, shapes) returns the view (scale, x, y, toWorld), on a canvas sized by
 * window.ArenaReplay.sizeCanvas(canvas, bounds, width, limits).
 * Needs window.Arena (app.js, loaded first): el, request.
 */
(function () {
  "use strict";

  var FRAMES_PER_SECOND = 10;
  var SPEEDS = [0.25, 0.5, 1, 2, 4];
  var PADDING = 12; // CSS pixels between the world bounds and the canvas edge
  var LIMITS = { least: 200, share: 0.7, lowest: 120 }; // see sizeCanvas
  var el = window.Arena.el;
  var players = [];
  var lastUsed = null;

  function formatScore(value) {
    if (typeof value !== "number" || !isFinite(value)) return String(value);
    return String(Number(value.toPrecision(3)));
  }

  function agentList(agents) {
    var counts = [];
    var index = {};
    agents.forEach(function (name) {
      if (index[name] === undefined) {
        index[name] = counts.length;
        counts.push([name, 0]);
      }
      counts[index[name]][1] += 1;
    });
    return counts.map(function (entry) {
      return entry[1] === 1 ? entry[0] : entry[0] + " x" + entry[1];
    }).join(", ");
  }

  function Player(root) {
    this.root = root;
    this.doc = null;
    this.frame = 0;
    this.playing = false;
    this.speed = 1;
    this.timer = null;
    this.cssWidth = 0;
    this.cssHeight = 0;
    this.dpr = 1;
    this.eventsByStep = {};
    this.observer = null;
    this.onResize = null;
    this.gone = false;
  }

  Player.prototype.load = function () {
    var self = this;
    var src = self.root.getAttribute("data-src");
    self.root.setAttribute("data-state", "loading");
    self.root.setAttribute("data-playing", "false");
    if (!src) {
      self.fail("no data-src attribute names the replay to show");
      return Promise.resolve();
    }
    return window.Arena.request("GET", src)
      .catch(function (error) {
        if (error.status === undefined) throw error; // not an answer of the server
        throw new Error("the server answered " + error.status + " " + error.statusText +
          (error.detail ? ": " + String(error.detail).slice(0, 300) : ""));
      })
      .then(function (doc) {
        if (self.gone) return;
        if (!doc || !Array.isArray(doc.frames) || doc.frames.length === 0 || !doc.match) {
          throw new Error("the replay document has no frames to show");
        }
        self.doc = doc;
        self.build();
        self.root.setAttribute("data-state", "ready");
      })
      .catch(function (error) {
        if (!self.gone) self.fail(window.Arena.messageOf(error));
      });
  };

  Player.prototype.fail = function (message) {
    this.pause();
    this.root.textContent = "";
    this.root.appendChild(el("p", { "class": "replay-error", role: "alert" },
      "Could not load the replay: " + message));
    this.root.setAttribute("data-state", "error");
    this.root.setAttribute("data-playing", "false");
  };

  Player.prototype.build = function () {
    var self = this;
    var doc = self.doc;
    var root = self.root;
    var match = doc.match;
    root.textContent = "";
    if (!root.hasAttribute("tabindex")) root.setAttribute("tabindex", "0");
    if (!root.hasAttribute("role")) root.setAttribute("role", "region");
    if (!root.hasAttribute("aria-label")) root.setAttribute("aria-label", "Replay of " + match.game_id);

    (doc.events || []).forEach(function (event) {
      (self.eventsByStep[event.step] = self.eventsByStep[event.step] || []).push(event);
    });
    self.teamOfSeat = {};
    (doc.teams || []).forEach(function (team) {
      (team.seats || []).forEach(function (seat) { self.teamOfSeat[seat] = team; });
    });

    var caption = el("div", { "class": "replay-caption", "data-role": "caption" });
    (doc.teams || []).forEach(function (team) {
      var item = el("span", { "class": "replay-team" });
      var swatch = el("span", { "class": "replay-swatch", "aria-hidden": "true" });
      swatch.style.background = team.color;
      var name = el("span", {}, "team " + team.team + ": " + agentList(team.agents || []));
      name.style.color = team.color;
      item.appendChild(swatch);
      item.appendChild(name);
      caption.appendChild(item);
    });
    caption.appendChild(el("span", { "class": "replay-game" }, match.game_id));

    self.view = el("div", { "class": "replay-view" });
    self.canvas = el("canvas", { "data-role": "view", role: "img",
      "aria-label": "Top-down view of the match" });
    self.view.appendChild(self.canvas);

    var status = el("div", { "class": "replay-status" });
    self.stepText = el("span", { "class": "replay-step", "data-role": "step", "aria-live": "off" });
    self.eventsText = el("span", { "class": "replay-events", "data-role": "events" });
    self.outcomeText = el("div", { "class": "replay-outcome", "data-role": "outcome", "aria-live": "polite" });
    self.outcomeText.hidden = true;
    status.appendChild(self.stepText);
    status.appendChild(self.eventsText);

    var controls = el("div", { "class": "replay-controls" });
    self.backButton = el("button", { type: "button", "data-role": "back", "aria-label": "Step back",
      title: "Step back (left arrow)" }, "\u25C0\u25C0");
    self.playButton = el("button", { type: "button", "data-role": "play", "aria-label": "Play",
      "aria-pressed": "false", title: "Play or pause (space)" }, "\u25B6");
    self.forwardButton = el("button", { type: "button", "data-role": "forward", "aria-label": "Step forward",
      title: "Step forward (right arrow)" }, "\u25B6\u25B6");
    self.speedSelect = el("select", { "data-role": "speed", "aria-label": "Playback speed" });
    SPEEDS.forEach(function (speed) {
      var option = el("option", { value: String(speed) }, speed + "x");
      if (speed === 1) option.selected = true;
      self.speedSelect.appendChild(option);
    });
    self.seek = el("input", { type: "range", min: "0", max: String(doc.frames.length - 1), step: "1",
      value: "0", "data-role": "seek", "aria-label": "Seek" });
    [self.backButton, self.playButton, self.forwardButton, self.speedSelect, self.seek].forEach(function (c) {
      controls.appendChild(c);
    });

    root.appendChild(caption);
    root.appendChild(self.view);
    root.appendChild(status);
    root.appendChild(self.outcomeText);
    root.appendChild(controls);

    self.playButton.addEventListener("click", function () { self.toggle(); });
    self.backButton.addEventListener("click", function () { self.pause(); self.show(self.frame - 1); });
    self.forwardButton.addEventListener("click", function () { self.pause(); self.show(self.frame + 1); });
    self.speedSelect.addEventListener("change", function () {
      var speed = Number(self.speedSelect.value);
      self.speed = speed > 0 ? speed : 1;
      if (self.playing) self.schedule();
    });
    self.seek.addEventListener("input", function () { self.show(Number(self.seek.value)); });
    function used() { if (!self.gone) lastUsed = self; } // (root may outlive the player: unmount)
    root.addEventListener("focusin", used);
    root.addEventListener("pointerdown", used);

    if (typeof ResizeObserver === "function") {
      self.observer = new ResizeObserver(function () { self.resize(); });
      self.observer.observe(self.view);
    }
    self.onResize = function () { self.resize(); };
    window.addEventListener("resize", self.onResize);

    self.resize();
    self.show(0);
  };

  // --- playback ------------------------------------------------------------------------------
  Player.prototype.show = function (index) {
    var frames = this.doc.frames;
    var last = frames.length - 1;
    index = Math.max(0, Math.min(last, Math.round(Number(index) || 0)));
    this.frame = index;
    this.root.setAttribute("data-frame", String(index));
    if (Number(this.seek.value) !== index) this.seek.value = String(index);
    var frame = frames[index];
    this.stepText.textContent = "step " + frame.step + " / " + this.doc.match.steps;
    this.showEvents(index);
    if (index === last) {
      this.showOutcome();
    } else {
      this.outcomeText.hidden = true;
      this.outcomeText.textContent = "";
    }
    this.draw();
    if (index === last && this.playing) this.pause();
  };

  Player.prototype.play = function () {
    if (this.playing) return;
    if (this.frame >= this.doc.frames.length - 1) this.show(0); // play again from the start
    this.setPlaying(true);
    this.schedule();
  };

  Player.prototype.pause = function () {
    if (this.timer !== null) {
      clearTimeout(this.timer);
      this.timer = null;
    }
    if (this.playing) this.setPlaying(false);
  };

  Player.prototype.toggle = function () {
    if (this.playing) this.pause(); else this.play();
  };

  Player.prototype.setPlaying = function (playing) {
    this.playing = playing;
    this.root.setAttribute("data-playing", playing ? "true" : "false");
    if (!this.playButton) return;
    this.playButton.textContent = playing ? "\u275A\u275A" : "\u25B6";
    this.playButton.setAttribute("aria-label", playing ? "Pause" : "Play");
    this.playButton.setAttribute("aria-pressed", playing ? "true" : "false");
  };

  Player.prototype.schedule = function () {
    var self = this;
    if (self.timer !== null) clearTimeout(self.timer);
    self.timer = setTimeout(function tick() {
      self.timer = null;
      if (!self.playing) return;
      self.show(self.frame + 1); // pauses itself on the last frame
      if (self.playing) self.timer = setTimeout(tick, 1000 / (FRAMES_PER_SECOND * self.speed));
    }, 1000 / (FRAMES_PER_SECOND * self.speed));
  };

  // --- text ----------------------------------------------------------------------------------
  Player.prototype.showEvents = function (index) {
    var frames = this.doc.frames;
    var from = index > 0 ? frames[index - 1].step + 1 : 0;
    var to = frames[index].step;
    var self = this;
    self.eventsText.textContent = "";
    for (var step = from; step <= to; step++) {
      (self.eventsByStep[step] || []).forEach(function (event) {
        self.eventsText.appendChild(self.describeEvent(event));
      });
    }
  };

  Player.prototype.describeEvent = function (event) {
    var item = el("span", { "class": "replay-event" });
    var details = event.event && typeof event.event === "object" ? event.event : {};
    var team = typeof details.seat === "number" ? this.teamOfSeat[details.seat] : undefined;
    item.appendChild(document.createTextNode(event.kind || "event"));
    if (team) {
      var who = el("span", {}, " " + this.doc.match.seats[details.seat] + " (seat " + details.seat + ")");
      who.style.color = team.color;
      item.appendChild(who);
    }
    var extra = Object.keys(details).filter(function (key) {
      return key !== "kind" && !(key === "seat" && team);
    }).map(function (key) {
      var value = details[key];
      return key + " " + (typeof value === "object" ? JSON.stringify(value) : String(value));
    });
    if (extra.length) item.appendChild(document.createTextNode(": " + extra.join(", ")));
    return item;
  };

  Player.prototype.showOutcome = function () {
    var teams = this.doc.teams || [];
    var line = this.outcomeText;
    line.textContent = "";
    var winners = teams.filter(function (team) { return team.outcome === "win"; });
    var verdict = el("span", { "class": "replay-verdict" });
    if (winners.length) {
      winners.forEach(function (team, i) {
        if (i) verdict.appendChild(document.createTextNode(" and "));
        var name = el("span", {}, "team " + team.team + " (" + agentList(team.agents || []) + ")");
        name.style.color = team.color;
        verdict.appendChild(name);
      });
      verdict.appendChild(document.createTextNode(winners.length === 1 ? " wins" : " win"));
    } else if (teams.length && teams.every(function (team) { return team.outcome === "draw"; })) {
      verdict.textContent = "draw";
    } else {
      var tied = teams.filter(function (team) { return team.outcome === "draw"; });
      verdict.textContent = tied.length
        ? "teams " + tied.map(function (team) { return team.team; }).join(", ") + " tie for first"
        : "no winner";
    }
    line.appendChild(verdict);
    var scores = el("span", { "class": "replay-scores" }, " \u2014 scores ");
    teams.forEach(function (team, i) {
      if (i) scores.appendChild(document.createTextNode(teams.length === 2 ? " : " : "  "));
      var score = el("span", {}, formatScore(team.score));
      score.style.color = team.color;
      scores.appendChild(score);
    });
    line.appendChild(scores);
    line.hidden = false;
  };

  // --- drawing -------------------------------------------------------------------------------
  Player.prototype.resize = function () {
    if (!this.doc) return;
    var size = sizeCanvas(this.canvas, this.doc.bounds, Math.max(1, this.view.clientWidth || 480), LIMITS);
    if (!size.changed) return;
    this.cssWidth = size.width;
    this.cssHeight = size.height;
    this.dpr = size.dpr;
    this.draw();
  };

  /* Size canvas to width CSS pixels and the height of the world rectangle bounds at that width,
     held between limits.lowest and the larger of limits.least and limits.share of the window's
     height; its pixels follow the device pixel ratio. Returns {width, height, dpr} in CSS pixels
     and whether it changed (resizing a canvas clears it: redraw then). */
  function sizeCanvas(canvas, bounds, width, limits) {
    var aspect = (bounds[3] - bounds[1]) / Math.max(1e-9, bounds[2] - bounds[0]);
    var tallest = Math.max(limits.least, (window.innerHeight || 800) * limits.share);
    var height = Math.max(limits.lowest, Math.min(tallest, Math.round(width * aspect)));
    var dpr = window.devicePixelRatio || 1;
    var size = { width: width, height: height, dpr: dpr, changed: false };
    var pixelsWide = Math.round(width * dpr);
    var pixelsHigh = Math.round(height * dpr);
    if (canvas.style.width === width + "px" && canvas.style.height === height + "px" &&
        canvas.width === pixelsWide && canvas.height === pixelsHigh) return size;
    canvas.style.width = width + "px";
    canvas.style.height = height + "px";
    canvas.width = pixelsWide;
    canvas.height = pixelsHigh;
    size.changed = true;
    return size;
  }

  Player.prototype.draw = function () {
    var canvas = this.canvas;
    var context = canvas.getContext && canvas.getContext("2d");
    if (!context || !this.doc) return;
    paint(context, this.dpr, this.cssWidth, this.cssHeight, this.doc.bounds,
          this.doc.frames[this.frame].shapes || []);
  };

  // The view that fits the world rectangle bounds [xmin, ymin, xmax, ymax] into width x height
  // CSS pixels, y up: its scale, x(world) and y(world) in CSS pixels, and back (toWorld).
  function fit(bounds, width, height) {
    var spanX = Math.max(1e-9, bounds[2] - bounds[0]);
    var spanY = Math.max(1e-9, bounds[3] - bounds[1]);
    var scale = Math.max(1e-9, Math.min((width - 2 * PADDING) / spanX, (height - 2 * PADDING) / spanY));
    var offsetX = (width - spanX * scale) / 2;
    var offsetY = (height - spanY * scale) / 2;
    return {
      scale: scale,
      x: function (x) { return offsetX + (x - bounds[0]) * scale; },
      y: function (y) { return offsetY + (bounds[3] - y) * scale; }, // y up
      toWorld: function (px, py) { return [bounds[0] + (px - offsetX) / scale, bounds[3] - (py - offsetY) / scale]; }
    };
  }

  // Draw shapes (a replay document frame's) on a 2D context of a canvas width x height CSS pixels
  // at device pixel ratio dpr, the world rectangle bounds fitted in.
  function paint(context, dpr, width, height, bounds, shapes) {
    var view = fit(bounds, width, height);
    context.setTransform(dpr, 0, 0, dpr, 0, 0);
    context.clearRect(0, 0, width, height);
    for (var i = 0; i < shapes.length; i++) {
      var shape = shapes[i];
      var draw = DRAW[shape.kind];
      if (!draw) continue;
      context.save();
      context.fillStyle = shape.color;
      context.strokeStyle = shape.color;
      draw(context, shape, view);
      context.restore();
    }
    return view;
  }

  var DRAW = {
    rect: function (context, shape, view) {
      var w = shape.w * view.scale;
      var h = shape.h * view.scale;
      context.translate(view.x(shape.x), view.y(shape.y));
      context.rotate(-shape.yaw); // the canvas' y axis points down
      context.fillRect(-w / 2, -h / 2, w, h);
    },
    circle: function (context, shape, view) {
      context.beginPath();
      context.arc(view.x(shape.x), view.y(shape.y), Math.max(0.75, shape.r * view.scale), 0, 2 * Math.PI);
      context.fill();
    },
    line: function (context, shape, view) {
      var points = shape.points || [];
      if (points.length < 2) return;
      context.lineWidth = Math.max(1, shape.screen ? shape.width : shape.width * view.scale);
      context.lineCap = "round";
      context.lineJoin = "round";
      context.beginPath();
      if (shape.segments) {
        for (var i = 0; i + 1 < points.length; i += 2) {
          context.moveTo(view.x(points[i][0]), view.y(points[i][1]));
          context.lineTo(view.x(points[i + 1][0]), view.y(points[i + 1][1]));
        }
      } else {
        context.moveTo(view.x(points[0][0]), view.y(points[0][1]));
        for (var j = 1; j < points.length; j++) context.lineTo(view.x(points[j][0]), view.y(points[j][1]));
        if (shape.closed) context.closePath();
      }
      context.stroke();
    },
    arrow: function (context, shape, view) {
      var x1 = view.x(shape.x);
      var y1 = view.y(shape.y);
      var x2 = view.x(shape.x2);
      var y2 = view.y(shape.y2);
      var length = Math.hypot(x2 - x1, y2 - y1);
      if (length < 0.5) return; // points straight up or down: nothing to see from above
      var ux = (x2 - x1) / length;
      var uy = (y2 - y1) / length;
      var head = Math.min(length, Math.max(3, shape.head_length * view.scale));
      var half = Math.max(2, shape.head_width * view.scale / 2);
      var baseX = x2 - ux * head;
      var baseY = y2 - uy * head;
      context.lineWidth = Math.max(1, shape.width * view.scale);
      context.lineCap = "round";
      context.beginPath();
      context.moveTo(x1, y1);
      context.lineTo(baseX, baseY);
      context.stroke();
      context.beginPath();
      context.moveTo(x2, y2);
      context.lineTo(baseX - uy * half, baseY + ux * half);
      context.lineTo(baseX + uy * half, baseY - ux * half);
      context.closePath();
      context.fill();
    },
    text: function (context, shape, view) {
      var size = Math.max(6, shape.screen ? shape.size : shape.size * view.scale);
      context.font = size + "px system-ui, -apple-system, 'Segoe UI', sans-serif";
      context.textAlign = "center";
      context.textBaseline = "middle";
      context.fillText(String(shape.text), view.x(shape.x), view.y(shape.y));
    }
  };

  // --- keyboard and start-up -----------------------------------------------------------------
  function onKey(event) {
    if (event.defaultPrevented || event.altKey || event.ctrlKey || event.metaKey) return;
    var key = event.key;
    if (key !== " " && key !== "Spacebar" && key !== "ArrowLeft" && key !== "ArrowRight") return;
    var target = event.target;
    var player = null;
    for (var i = 0; i < players.length; i++) {
      if (players[i].root.contains(target)) player = players[i];
    }
    if (!player) {
      var onPage = target === document.body || target === document.documentElement || !target;
      if (!onPage) return; // typing somewhere else on the page
      var ready = players.filter(function (p) { return p.doc; });
      player = lastUsed && lastUsed.doc ? lastUsed : (ready.length === 1 ? ready[0] : null);
    }
    if (!player || !player.doc) return;
    var tag = target && target.tagName ? target.tagName.toLowerCase() : "";
    if (tag === "input" || tag === "select" || tag === "textarea") return; // the control's own keys
    if (key === "ArrowLeft" || key === "ArrowRight") {
      event.preventDefault();
      player.pause();
      player.show(player.frame + (key === "ArrowLeft" ? -1 : 1));
    } else {
      if (tag === "button") return; // a focused button answers space itself
      event.preventDefault();
      player.toggle();
    }
  }

  function mount(root) {
    if (!root || root.__arenaReplay) return root && root.__arenaReplay;
    var player = new Player(root);
    root.__arenaReplay = player;
    players.push(player);
    player.load();
    return player;
  }

  /* Stop the player of root (before root leaves the page): no timer, listener or observer stays. */
  function unmount(root) {
    var player = root && root.__arenaReplay;
    if (!player) return;
    player.gone = true;
    player.pause();
    players = players.filter(function (other) { return other !== player; });
    if (lastUsed === player) lastUsed = null;
    if (player.observer) player.observer.disconnect();
    if (player.onResize) window.removeEventListener("resize", player.onResize);
    player.observer = null;
    player.onResize = null;
    delete root.__arenaReplay;
  }

  function mountAll() {
    var roots = document.querySelectorAll("div.replay-player[data-src]");
    for (var i = 0; i < roots.length; i++) mount(roots[i]);
  }

  document.addEventListener("keydown", onKey);
  window.ArenaReplay = { mount: mount, unmount: unmount, paint: paint, sizeCanvas: sizeCanvas };
  if (document.readyState === "loading") {
    document.addEventListener("DOMContentLoaded", mountAll);
  } else {
    mountAll();
  }
})();
