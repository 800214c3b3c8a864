/*
 * Arena league social-tree editor: plain JavaScript, no build step, no dependencies.
 *
 * Mounts on <div id="tree-editor" data-game="GAME" data-tree="ID or empty" data-signed-in="yes|no">.
 * It loads /api/games/GAME/tree-catalog (and /api/trees/ID for a saved tree), shows the social
 * tree as nested cards (a node: scheme, reward function, its parameters, scale, broadcast board;
 * agents are chips inside), checks it on every edit with /api/trees/check, and runs the
 * verification and preview jobs and saves it through /api/trees with the sign-in cookie.
 *
 * Moving things: drag an agent chip, or a node by its grip, onto any node card (HTML5 drag and
 * drop; a node never into itself or its descendants). Without a mouse: focus a chip or a grip,
 * press Enter or Space to pick it up, then "Move here" on the node to put it in (Escape cancels).
 *
 * Contract for tests (data-role): node cards [data-role="node"][data-path], agent chips
 * [data-role="leaf"][data-agent][data-path]; on a card: scheme, reward, param-NAME, scale, board,
 * label, add-node, duplicate, delete, grip, drop-here; the verification badge verified with its
 * verified-scheme; page controls example-NAME (example-default), undo, check (data-state
 * pending|ok|error), verify, samples, preview, seed, job (data-state), preview-result,
 * tree-name, save, saved, download-yaml, download-json, tree-link, spec, spec-format.
 * Needs window.Arena (app.js, loaded first) and, for the preview, window.ArenaReplay (replay.js).
 */
(function () {
  "use strict";

  var GREY = "#8a939c"; // an agent of no team
  var CHECK_DELAY_MS = 250;
  var UNDO_DEPTH = 60;
  var TREE_NAME = /^[A-Za-z0-9][A-Za-z0-9 ._-]{0,63}$/;
  var el = window.Arena.el;
  var request = window.Arena.request;
  var messageOf = window.Arena.messageOf;
  var nextUid = 1;

  // --- small helpers ---------------------------------------------------------------------------
  function isObject(value) {
    return value !== null && typeof value === "object" && !Array.isArray(value);
  }

  function copyPlain(value) {
    return value === undefined ? undefined : JSON.parse(JSON.stringify(value));
  }

  /* A status line: its data-state (the page's CSS colours it by that) and its content, text or a
     list of text and nodes. */
  function setStatus(line, state, content) {
    line.hidden = false;
    line.setAttribute("data-state", state);
    line.replaceChildren.apply(line, Array.isArray(content) ? content : [content]);
  }

  // --- YAML, as yaml.safe_dump(sort_keys=False) writes a spec ----------------------------------
  var YAML_PLAIN = /^[A-Za-z_][A-Za-z0-9_.\/-]*$/;
  var YAML_WORDS = /^(true|false|yes|no|on|off|null|y|n|~)$/i;

  function yamlScalar(value) {
    if (value === null || value === undefined) return "null";
    if (typeof value === "number") {
      if (!isFinite(value)) return isNaN(value) ? ".nan" : (value > 0 ? ".inf" : "-.inf");
      return String(value);
    }
    if (typeof value === "boolean") return value ? "true" : "false";
    var text = String(value);
    if (YAML_PLAIN.test(text) && !YAML_WORDS.test(text)) return text;
    return "'" + text.replace(/'/g, "''") + "'";
  }

  function yamlLines(value, indent) {
    var pad = new Array(indent + 1).join(" ");
    var lines = [];
    if (Array.isArray(value)) {
      value.forEach(function (item) {
        if (isObject(item) && Object.keys(item).length) {
          var inner = yamlLines(item, indent + 2);
          inner[0] = pad + "- " + inner[0].slice(indent + 2);
          lines = lines.concat(inner);
        } else if (Array.isArray(item) && item.length) {
          lines.push(pad + "-");
          lines = lines.concat(yamlLines(item, indent + 2));
        } else {
          lines.push(pad + "- " + yamlInline(item));
        }
      });
      return lines;
    }
    Object.keys(value).forEach(function (key) {
      var item = value[key];
      if (Array.isArray(item) && item.length) {
        lines.push(pad + yamlScalar(key) + ":");
        lines = lines.concat(yamlLines(item, indent));
      } else if (isObject(item) && Object.keys(item).length) {
        lines.push(pad + yamlScalar(key) + ":");
        lines = lines.concat(yamlLines(item, indent + 2));
      } else {
        lines.push(pad + yamlScalar(key) + ": " + yamlInline(item));
      }
    });
    return lines;
  }

  function yamlInline(value) {
    if (Array.isArray(value)) return "[]";
    if (isObject(value)) return "{}";
    return yamlScalar(value);
  }

  function toYaml(value) {
    return yamlLines(value, 0).join("\n") + "\n";
  }

  // --- the model: nodes and agent leaves with ids, to and from the JSON spec --------------------
  /* node: {kind: "node", uid, scheme, reward, scale, params, board, name, children}
     leaf: {kind: "leaf", uid, agent, own: null or {scheme, reward, scale, params, name}} */
  function fromSpec(raw) {
    if (typeof raw === "string") return { kind: "leaf", uid: nextUid++, agent: raw, own: null };
    if (!isObject(raw)) return { kind: "leaf", uid: nextUid++, agent: String(raw), own: null };
    if (raw.agent !== undefined) {
      var own = null;
      if (raw.scheme !== undefined || raw.reward !== undefined) {
        own = { scheme: raw.scheme, reward: raw.reward, scale: raw.scale === undefined ? 1 : raw.scale,
                params: isObject(raw.params) ? copyPlain(raw.params) : {}, name: raw.name || "" };
      }
      return { kind: "leaf", uid: nextUid++, agent: String(raw.agent), own: own };
    }
    return {
      kind: "node", uid: nextUid++, scheme: raw.scheme, reward: raw.reward,
      scale: raw.scale === undefined ? 1 : raw.scale,
      params: isObject(raw.params) ? copyPlain(raw.params) : {},
      board: typeof raw.board === "number" ? raw.board : 0,
      name: typeof raw.name === "string" ? raw.name : "",
      children: Array.isArray(raw.children) ? raw.children.map(fromSpec) : []
    };
  }

  function rewardFields(target, item) {
    target.scheme = item.scheme;
    target.reward = item.reward;
    target.scale = item.scale;
    if (item.params && Object.keys(item.params).length) target.params = copyPlain(item.params);
  }

  /* The spec make(game, tree=...) takes, keys in the order scheme, reward, scale, params, board,
     name, children (a leaf: agent first). */
  function toSpec(item) {
    var out = {};
    if (item.kind === "leaf") {
      if (!item.own) return item.agent;
      out.agent = item.agent;
      rewardFields(out, item.own);
      if (item.own.name) out.name = item.own.name;
      return out;
    }
    rewardFields(out, item);
    if (typeof item.board === "number" && item.board > 0) out.board = item.board;
    if (item.name) out.name = item.name;
    out.children = item.children.map(toSpec);
    return out;
  }

  function cloneItem(item) {
    return fromSpec(toSpec(item));
  }

  // --- the editor ------------------------------------------------------------------------------
  function Editor(root) {
    this.root = root;
    this.game = root.getAttribute("data-game");
    this.treeId = root.getAttribute("data-tree") || "";
    this.signedIn = root.getAttribute("data-signed-in") === "yes";
    this.catalog = null;
    this.tree = null;
    this.index = {};
    this.undo = [];
    this.picked = null; // uid picked up with the keyboard (or a click) to move
    this.dragging = null; // uid being dragged
    this.checkTimer = null;
    this.checkSeq = 0;
    this.lastCheck = null;
    this.verified = null; // {spec: JSON text, result}
    this.spec = null; // the tree as its spec, and that as JSON text: set by changed()
    this.text = null;
    this.specFormat = "yaml";
    this.busy = {};
  }

  Editor.prototype.start = function () {
    var self = this;
    self.root.setAttribute("data-state", "loading");
    self.root.appendChild(el("p", { "class": "meta" }, "Loading the social-tree catalog of " + self.game + "\u2026"));
    var loads = [request("GET", "/api/games/" + encodeURIComponent(self.game) + "/tree-catalog")];
    if (self.treeId) loads.push(request("GET", "/api/trees/" + encodeURIComponent(self.treeId)));
    Promise.all(loads).then(function (answers) {
      self.catalog = answers[0];
      var saved = answers[1];
      self.build();
      if (saved) {
        self.nameInput.value = saved.name;
        self.showSaved(saved, true);
      }
      self.setTree(fromSpec(saved ? saved.spec : self.catalog["default"]), false);
      self.root.setAttribute("data-state", "ready");
    }).catch(function (error) {
      self.root.textContent = "";
      self.root.appendChild(el("p", { "class": "reason", role: "alert" },
        "Could not load the editor: " + messageOf(error)));
      self.root.setAttribute("data-state", "error");
    });
  };

  // --- catalog lookups ---
  Editor.prototype.functionsOf = function (scheme) {
    return (this.catalog.rewards && this.catalog.rewards[scheme]) || [];
  };

  Editor.prototype.functionOf = function (scheme, name) {
    var found = null;
    this.functionsOf(scheme).forEach(function (fn) { if (fn.name === name) found = fn; });
    return found;
  };

  Editor.prototype.teamOf = function (agent) {
    var seat = this.catalog.agents.indexOf(agent);
    return seat < 0 ? -1 : this.catalog.teams[seat];
  };

  /* The team's colour as the server draws it (the catalog's colors), grey for no team. */
  Editor.prototype.colourOf = function (team) {
    return (team >= 0 && (this.catalog.colors || [])[team]) || GREY;
  };

  // --- page layout ---
  Editor.prototype.build = function () {
    var self = this;
    var root = self.root;
    root.textContent = "";
    root.classList.add("tree-editor");
    if (self.catalog.match_format && self.catalog.match_format.note) {
      root.appendChild(el("p", { "class": "meta", "data-role": "match-format" }, self.catalog.match_format.note));
    }

    // examples
    var examples = el("div", { "class": "tree-bar", role: "group", "aria-label": "Start from" },
      el("span", { "class": "tree-bar-label" }, "Start from"));
    var names = [["default", "Default"]];
    Object.keys(self.catalog.examples || {}).forEach(function (name) { names.push([name, name]); });
    names.forEach(function (pair) {
      var button = el("button", { type: "button", "class": "secondary", "data-role": "example-" + pair[0],
        title: pair[0] === "default" ? "the game's default tree" : "the example tree " + pair[0] }, pair[1]);
      button.addEventListener("click", function () { self.loadExample(pair[0]); });
      examples.appendChild(button);
    });
    self.undoButton = el("button", { type: "button", "class": "secondary", "data-role": "undo", disabled: true,
      title: "undo the last edit" }, "Undo");
    self.undoButton.addEventListener("click", function () { self.undoEdit(); });
    examples.appendChild(self.undoButton);

    // actions
    var actions = el("div", { "class": "tree-bar tree-actions" });
    self.samplesInput = el("input", { type: "number", min: 2, max: 512, step: 1, value: 64, "data-role": "samples",
      "class": "narrow" });
    self.seedInput = el("input", { type: "number", min: 0, step: 1, value: 0, "data-role": "seed", "class": "narrow" });
    self.verifyButton = el("button", { type: "button", "data-role": "verify",
      title: "estimate every node's scheme by paired sampling (the paper's verification)" }, "Verify");
    self.previewButton = el("button", { type: "button", "data-role": "preview",
      title: "play one recorded match of the scripted players under this tree" }, "Preview");
    self.nameInput = el("input", { type: "text", "data-role": "tree-name", maxlength: 64, placeholder: "tree name",
      pattern: "[A-Za-z0-9][A-Za-z0-9 ._\\-]{0,63}", "aria-label": "Tree name",
      title: "1 to 64 letters, digits, spaces and . _ -, starting with a letter or digit" });
    self.saveButton = el("button", { type: "button", "data-role": "save" }, "Save");
    self.verifyButton.addEventListener("click", function () { self.runVerify(); });
    self.previewButton.addEventListener("click", function () { self.runPreview(); });
    self.saveButton.addEventListener("click", function () { self.save(); });
    self.nameInput.addEventListener("keydown", function (event) {
      if (event.key === "Enter") { event.preventDefault(); self.save(); }
    });
    actions.appendChild(el("span", { "class": "tree-action" }, [self.verifyButton,
      el("label", {}, ["samples ", self.samplesInput])]));
    actions.appendChild(el("span", { "class": "tree-action" }, [self.previewButton,
      el("label", {}, ["seed ", self.seedInput])]));
    actions.appendChild(el("span", { "class": "tree-action" }, [self.nameInput, self.saveButton]));
    if (!self.signedIn) {
      [self.verifyButton, self.previewButton, self.saveButton, self.nameInput].forEach(function (control) {
        control.disabled = true;
      });
      var next = window.location.pathname + window.location.search;
      actions.appendChild(el("a", { href: "/signin?next=" + encodeURIComponent(next), "data-role": "signin" },
        "Sign in to verify, preview and save"));
    }

    // status lines
    self.checkLine = el("p", { "class": "tree-check", "data-role": "check", "data-state": "pending",
      role: "status", "aria-live": "polite" }, "Checking\u2026");
    self.jobLine = el("p", { "class": "tree-job", "data-role": "job", "aria-live": "polite", hidden: true });
    self.savedArea = el("div", { "class": "tree-saved", "data-role": "saved", hidden: true, "aria-live": "polite" });
    self.pickLine = el("p", { "class": "tree-pick", role: "status", hidden: true });

    // the tree, and its spec as text
    self.treeArea = el("div", { "class": "tree-canvas", "data-role": "tree" });
    self.bindTree(self.treeArea);
    self.specPre = el("pre", { "class": "log tree-spec", "data-role": "spec", tabindex: 0,
      "aria-label": "The tree as text" });
    self.formatSelect = el("select", { "data-role": "spec-format", "aria-label": "Text format" }, [
      el("option", { value: "yaml", selected: true }, "YAML"), el("option", { value: "json" }, "JSON")]);
    self.formatSelect.addEventListener("change", function () {
      self.specFormat = self.formatSelect.value;
      self.showSpec();
    });
    var side = el("aside", { "class": "tree-side" }, [
      el("div", { "class": "tree-side-head" }, [el("h2", {}, "As text"), self.formatSelect]),
      el("p", { "class": "meta" }, "What make(\"" + self.game + "\", tree=...) and arena-league verify --tree read."),
      self.specPre, self.schemeHelp()]);
    self.previewArea = el("section", { "class": "tree-preview", "data-role": "preview-result", hidden: true,
      "aria-label": "Preview" });

    root.appendChild(examples);
    root.appendChild(actions);
    root.appendChild(self.checkLine);
    root.appendChild(self.jobLine);
    root.appendChild(self.savedArea);
    root.appendChild(self.pickLine);
    root.appendChild(el("div", { "class": "tree-layout" }, [self.treeArea, side]));
    root.appendChild(self.previewArea);
    document.addEventListener("keydown", function (event) {
      if (event.key === "Escape" && self.picked !== null) {
        self.pick(null);
      }
    });
  };

  Editor.prototype.schemeHelp = function () {
    var list = el("dl", { "class": "tree-schemes" });
    this.catalog.schemes.forEach(function (scheme) {
      list.appendChild(el("dt", { "class": "scheme-" + scheme.name }, scheme.name));
      list.appendChild(el("dd", {}, scheme.doc));
    });
    var teams = el("p", { "class": "tree-legend" }, "Agents by team: ");
    var self = this;
    self.catalog.agents.forEach(function (agent, seat) {
      var team = self.catalog.teams[seat];
      teams.appendChild(el("span", { "class": "tree-swatch", style: "background:" + self.colourOf(team) },
        agent + " (team " + team + ")"));
    });
    return el("details", { "class": "tree-help" }, [el("summary", {}, "Schemes and teams"), list, teams]);
  };

  // --- state changes ---
  Editor.prototype.setTree = function (tree, remember) {
    if (remember && this.tree) this.remember();
    this.tree = tree;
    this.picked = null;
    this.changed();
    this.render();
  };

  /* One edit of the tree: remembered for undo, made by mutate, then the text, the check and the
     cards follow; mutate may return [uid, role] of the control to focus after. The cards are drawn
     after changed() serialised the tree, since they show the check and the verification of that
     text. */
  Editor.prototype.edit = function (mutate) {
    this.remember();
    var focus = mutate.call(this);
    this.changed();
    this.render();
    if (focus) this.refocus(String(focus[0]), focus[1]);
  };

  Editor.prototype.remember = function () {
    this.undo.push(this.text);
    if (this.undo.length > UNDO_DEPTH) this.undo.shift();
    this.undoButton.disabled = false;
  };

  Editor.prototype.undoEdit = function () {
    if (!this.undo.length) return;
    this.setTree(fromSpec(JSON.parse(this.undo.pop())), false);
    this.undoButton.disabled = !this.undo.length;
  };

  Editor.prototype.loadExample = function (name) {
    var spec = name === "default" ? this.catalog["default"] : this.catalog.examples[name];
    if (spec) this.setTree(fromSpec(spec), true);
  };

  /* After any edit: the tree serialised (once: this.spec and its JSON text this.text), the text
     view, and a check soon. The cards' verification paint is render's (or, for an edit made in
     place, onInput's). */
  Editor.prototype.changed = function () {
    var self = this;
    self.spec = toSpec(self.tree);
    self.text = JSON.stringify(self.spec);
    self.showSpec();
    self.markStale();
    setStatus(self.checkLine, "pending", "Checking\u2026");
    if (self.checkTimer) clearTimeout(self.checkTimer);
    self.checkTimer = setTimeout(function () { self.checkTimer = null; self.check(); }, CHECK_DELAY_MS);
  };

  Editor.prototype.showSpec = function () {
    this.specPre.textContent = this.specFormat === "json" ? JSON.stringify(this.spec, null, 2) + "\n"
      : toYaml(this.spec);
  };

  // --- checking ---
  Editor.prototype.check = function () {
    var self = this;
    var seq = ++self.checkSeq;
    var text = self.text;
    request("POST", "/api/trees/check", { game: self.game, spec: self.spec }).then(function (answer) {
      if (seq !== self.checkSeq) return;
      self.lastCheck = { spec: text, answer: answer };
      self.showCheck();
    }).catch(function (error) {
      if (seq !== self.checkSeq) return;
      self.lastCheck = { spec: text, answer: { ok: false, error: messageOf(error), path: null } };
      self.showCheck();
    });
  };

  Editor.prototype.showCheck = function () {
    var self = this;
    var answer = self.lastCheck && self.lastCheck.spec === self.text ? self.lastCheck.answer : null;
    self.markInvalid(answer && !answer.ok ? answer.path : null);
    if (!answer) return;
    if (answer.ok) {
      var nodes = (answer.nodes || []).length;
      setStatus(self.checkLine, "ok", [el("strong", {}, "ok"), " \u2014 the library builds this tree: " + nodes +
        (nodes === 1 ? " rewarded node" : " rewarded nodes and leaves") + ", each of the " + self.catalog.agents.length +
        " agents of " + self.game + " a leaf once."]);
      return;
    }
    var parts = [el("strong", {}, "Not a valid tree: "), el("span", { "data-role": "check-message" }, answer.error)];
    var path = answer.path;
    if (path && self.findPath(path)) {
      var show = el("button", { type: "button", "class": "secondary link", "data-role": "show-error" }, "show " + path);
      show.addEventListener("click", function () { self.showNode(path); });
      parts.push(" ", show);
    }
    setStatus(self.checkLine, "error", parts);
  };

  Editor.prototype.markInvalid = function (path) {
    var marked = this.treeArea.querySelectorAll(".invalid");
    Array.prototype.forEach.call(marked, function (node) {
      node.classList.remove("invalid");
      node.removeAttribute("data-invalid");
      node.removeAttribute("aria-invalid");
    });
    if (!path) return;
    var target = this.findPath(path);
    if (!target) return;
    target.classList.add("invalid");
    target.setAttribute("data-invalid", "true");
    target.setAttribute("aria-invalid", "true");
    if (target.getAttribute("data-role") === "leaf") {
      var card = target.parentNode && target.parentNode.closest('[data-role="node"]');
      if (card) {
        card.classList.add("invalid");
        card.setAttribute("data-invalid", "within");
      }
    }
  };

  /* Scroll to the node (or leaf) the check's message names and focus it. */
  Editor.prototype.showNode = function (path) {
    var target = this.findPath(path);
    if (!target) return;
    if (target.scrollIntoView) target.scrollIntoView({ behavior: "smooth", block: "center" });
    var focusable = target.getAttribute("data-role") === "leaf" ? target : target.querySelector("select, input, button");
    if (focusable) focusable.focus({ preventScroll: true });
  };

  Editor.prototype.findPath = function (path) {
    var found = null;
    Array.prototype.forEach.call(this.treeArea.querySelectorAll("[data-path]"), function (node) {
      if (node.getAttribute("data-path") === path) found = node;
    });
    return found;
  };

  // --- drawing the tree ---
  Editor.prototype.reindex = function () {
    var index = {};
    function walk(item, parent, path) {
      index[item.uid] = { item: item, parent: parent, path: path };
      if (item.kind === "node") {
        item.children.forEach(function (child, k) {
          walk(child, item, child.kind === "leaf" ? path + "/" + child.agent : path + "/" + k);
        });
      }
    }
    walk(this.tree, null, "root");
    this.index = index;
  };

  Editor.prototype.render = function () {
    var active = document.activeElement;
    var focus = null;
    if (active && this.treeArea.contains(active)) {
      var owner = active.closest("[data-uid]");
      if (owner) focus = { uid: owner.getAttribute("data-uid"), role: active.getAttribute("data-role") };
    }
    this.reindex();
    this.treeArea.textContent = "";
    this.treeArea.appendChild(this.renderNode(this.tree));
    this.treeArea.classList.toggle("picking", this.picked !== null);
    this.showPick();
    if (this.lastCheck) this.showCheck();
    this.paintVerification();
    if (focus) this.refocus(focus.uid, focus.role);
  };

  Editor.prototype.refocus = function (uid, role) {
    var owner = this.treeArea.querySelector('[data-uid="' + uid + '"]');
    if (!owner) return;
    var target = owner;
    if (role && owner.getAttribute("data-role") !== role) {
      var candidates = owner.querySelectorAll('[data-role="' + role + '"]');
      target = null;
      Array.prototype.forEach.call(candidates, function (candidate) {
        if (!target && candidate.closest("[data-uid]") === owner) target = candidate;
      });
      if (!target) target = owner.querySelector("select, input, button") || owner;
    }
    if (target && target.focus) target.focus();
  };

  /* A select with attributes, an option per choice ({value, doc, text: value when absent}) and
     current selected; a current value not among the choices is added, named by unknown(current). */
  function choiceSelect(attributes, choices, current, unknown) {
    var known = false;
    var options = choices.map(function (choice) {
      if (choice.value === current) known = true;
      return el("option", { value: choice.value, title: choice.doc, selected: choice.value === current },
        choice.text === undefined ? choice.value : choice.text);
    });
    if (!known) {
      options.push(el("option", { value: current === undefined ? "" : current, selected: true }, unknown(current)));
    }
    return el("select", attributes, options);
  }

  /* Choices of catalog entries ({name, doc}: schemes, reward functions), prefix before each name. */
  function namedChoices(entries, prefix) {
    return entries.map(function (entry) { return { value: (prefix || "") + entry.name, doc: entry.doc }; });
  }

  Editor.prototype.renderNode = function (node) {
    var self = this;
    var info = self.index[node.uid];
    var isRoot = info.parent === null;
    var card = el("section", { "class": "tree-node scheme-" + node.scheme, "data-role": "node", "data-uid": node.uid,
      "data-path": info.path, "data-scheme": node.scheme, "aria-label": "node " + info.path });
    if (self.picked === node.uid) card.classList.add("moving");

    // first row: grip, path, label, verdict, buttons; second row: the reward's fields
    var head = el("div", { "class": "tree-node-head" });
    if (!isRoot) {
      head.appendChild(el("span", { role: "button", tabindex: 0, "class": "grip", "data-role": "grip", draggable: "true",
        "aria-pressed": self.picked === node.uid ? "true" : "false",
        title: "drag this node into another node, or press Enter to pick it up and choose where it goes",
        "aria-label": "move node " + info.path }, "\u2630"));
    }
    head.appendChild(el("span", { "class": "tree-path" }, info.path));
    head.appendChild(el("input", { type: "text", "data-role": "label", "class": "label", value: node.name || "",
      placeholder: "label (optional)", maxlength: 64, "aria-label": "label of node " + info.path }));
    head.appendChild(el("span", { "class": "tree-badge", "data-role": "verified", hidden: true }));

    var buttons = el("div", { "class": "tree-node-buttons" });
    if (self.picked !== null && self.canMove(self.picked, node.uid)) {
      buttons.appendChild(el("button", { type: "button", "data-role": "drop-here", "class": "drop-here" }, "Move here"));
    }
    buttons.appendChild(el("button", { type: "button", "class": "secondary", "data-role": "add-node",
      title: "add an empty team node under this one" }, "Add team node"));
    buttons.appendChild(el("button", { type: "button", "class": "secondary", "data-role": "duplicate", disabled: isRoot,
      title: isRoot ? "the root cannot be duplicated" : "add a copy of this node after it" }, "Duplicate"));
    buttons.appendChild(el("button", { type: "button", "class": "secondary danger", "data-role": "delete",
      disabled: isRoot, title: isRoot ? "the root cannot be deleted"
        : "remove this node; what it holds moves up to its parent" }, "Delete"));
    head.appendChild(buttons);
    card.appendChild(head);

    var fields = el("div", { "class": "tree-fields" });
    fields.appendChild(el("label", {}, ["scheme ", choiceSelect({ "data-role": "scheme",
      "aria-label": "scheme of node " + info.path }, namedChoices(self.catalog.schemes), node.scheme,
      function (current) { return current === undefined ? "(none)" : String(current); })]));
    fields.appendChild(el("label", {}, ["reward ", choiceSelect({ "data-role": "reward",
      "aria-label": "reward function of node " + info.path }, namedChoices(self.functionsOf(node.scheme)),
      node.reward, function (current) {
        return current === undefined ? "(scheme default)" : String(current) + " (not offered)";
      })]));
    var fn = self.functionOf(node.scheme, node.reward);
    self.paramFields(node.params, fn).forEach(function (field) { fields.appendChild(field); });
    fields.appendChild(el("label", {}, ["scale ", el("input", { type: "number", step: "any", "class": "narrow",
      "data-role": "scale", value: node.scale === undefined || node.scale === null ? "" : node.scale,
      "aria-label": "scale of node " + info.path })]));
    fields.appendChild(el("label", { title: "floats of a broadcast board the agents below this node write and read " +
      "(0: none)" }, ["board ", el("input", { type: "number", min: 0, max: self.catalog.limits.board, step: 1,
        "class": "tiny", "data-role": "board", value: node.board || 0,
        "aria-label": "broadcast board size of node " + info.path })]));
    card.appendChild(fields);
    if (fn && fn.doc) card.appendChild(el("p", { "class": "tree-doc" }, fn.doc));

    var children = el("div", { "class": "tree-children", role: "group", "aria-label": "children of " + info.path });
    node.children.forEach(function (child) {
      children.appendChild(child.kind === "leaf" ? self.renderLeaf(child) : self.renderNode(child));
    });
    if (!node.children.length) {
      children.appendChild(el("p", { "class": "tree-empty" }, "Empty: drop agents or nodes here."));
    }
    card.appendChild(children);
    return card;
  };

  Editor.prototype.paramFields = function (params, fn) {
    var fields = [];
    var defaults = (fn && fn.params) || {};
    var names = Object.keys(defaults);
    Object.keys(params || {}).forEach(function (name) { if (names.indexOf(name) < 0) names.push(name); });
    names.forEach(function (name) {
      var known = Object.prototype.hasOwnProperty.call(defaults, name);
      var fallback = defaults[name];
      var has = params && Object.prototype.hasOwnProperty.call(params, name);
      var value = has ? params[name] : fallback;
      var input;
      var attrs = { "data-role": "param-" + name, "data-param": name, "aria-label": "parameter " + name,
        title: known ? "default " + JSON.stringify(fallback) : "not a parameter of this function" };
      var kind = typeof (known ? fallback : value);
      if (kind === "boolean") {
        attrs.type = "checkbox";
        attrs.checked = Boolean(value);
        attrs["data-kind"] = "boolean";
      } else if (kind === "number") {
        attrs.type = "number";
        attrs.step = "any";
        attrs["class"] = "narrow";
        attrs.value = typeof value === "number" ? value : "";
        attrs["data-kind"] = "number";
      } else if (kind === "string") {
        attrs.type = "text";
        attrs["class"] = "short";
        attrs.value = value === undefined || value === null ? "" : String(value);
        attrs["data-kind"] = "string";
      } else {
        attrs.type = "text";
        attrs.value = value === undefined ? "" : JSON.stringify(value);
        attrs["data-kind"] = "json";
      }
      input = el("input", attrs);
      fields.push(el("label", { "class": known ? "param" : "param unknown" }, [name + " ", input]));
    });
    return fields;
  };

  Editor.prototype.renderLeaf = function (leaf) {
    var self = this;
    var info = self.index[leaf.uid];
    var team = self.teamOf(leaf.agent);
    var chip = el("div", { "class": "tree-leaf", "data-role": "leaf", "data-uid": leaf.uid, "data-agent": leaf.agent,
      "data-path": info.path, "data-team": team, draggable: "true", tabindex: 0, role: "button",
      "aria-pressed": self.picked === leaf.uid ? "true" : "false",
      "aria-label": leaf.agent + (team >= 0 ? " (team " + team + ")" : "") + ": drag onto a node, or press Enter to move",
      title: "drag onto a node card, or press Enter and choose 'Move here'" });
    chip.style.setProperty("--team", self.colourOf(team));
    if (self.picked === leaf.uid) chip.classList.add("moving");
    chip.appendChild(el("span", { "class": "tree-leaf-dot", "aria-hidden": "true" }));
    chip.appendChild(el("span", { "class": "tree-leaf-name", "data-role": "leaf-name" }, leaf.agent));
    // its own reward: none, or an IS / NL function
    var choices = [{ value: "", text: "no own reward" }].concat(namedChoices(self.functionsOf("IS"), "IS/"),
      namedChoices(self.functionsOf("NL"), "NL/"));
    chip.appendChild(choiceSelect({ "data-role": "leaf-reward", "aria-label": "own reward of " + leaf.agent,
      title: "a reward of this agent alone (IS or NL)", draggable: "false" }, choices,
      leaf.own ? leaf.own.scheme + "/" + leaf.own.reward : "", String));
    if (leaf.own) {
      chip.appendChild(el("label", { "class": "tree-leaf-scale" }, ["\u00d7", el("input", { type: "number", step: "any",
        "data-role": "leaf-scale", value: leaf.own.scale, "aria-label": "scale of " + leaf.agent + "'s own reward",
        draggable: "false" })]));
    }
    chip.appendChild(el("span", { "class": "tree-badge small", "data-role": "verified", hidden: true }));
    return chip;
  };

  // --- editing through the tree (one set of listeners, delegated) ---
  Editor.prototype.bindTree = function (area) {
    var self = this;
    area.addEventListener("click", function (event) { self.onClick(event); });
    area.addEventListener("keydown", function (event) { self.onKey(event); });
    area.addEventListener("input", function (event) { self.onInput(event, false); });
    area.addEventListener("change", function (event) { self.onInput(event, true); });
    area.addEventListener("dragstart", function (event) { self.onDragStart(event); });
    area.addEventListener("dragover", function (event) { self.onDragOver(event); });
    area.addEventListener("dragleave", function (event) { self.onDragLeave(event); });
    area.addEventListener("drop", function (event) { self.onDrop(event); });
    area.addEventListener("dragend", function () { self.endDrag(); });
  };

  Editor.prototype.itemOf = function (element) {
    var owner = element && element.closest ? element.closest("[data-uid]") : null;
    return owner ? this.index[owner.getAttribute("data-uid")] : null;
  };

  Editor.prototype.onClick = function (event) {
    var control = event.target.closest("button, [data-role='leaf'], [data-role='grip']");
    if (!control || !this.treeArea.contains(control)) return;
    var role = control.getAttribute("data-role");
    var info = this.itemOf(control);
    if (!info) return;
    if (role === "leaf" || role === "grip") {
      if (event.target.closest("select, input, label")) return; // a chip's own controls
      this.pick(this.picked === info.item.uid ? null : info.item.uid);
    } else if (role === "drop-here") {
      var moving = this.picked;
      this.picked = null;
      this.move(moving, info.item.uid);
    } else if (role === "add-node") {
      this.addNode(info.item);
    } else if (role === "duplicate") {
      this.duplicate(info);
    } else if (role === "delete") {
      this.remove(info);
    }
  };

  Editor.prototype.onKey = function (event) {
    var target = event.target;
    var role = target.getAttribute("data-role");
    if ((role === "leaf" || role === "grip") && (event.key === "Enter" || event.key === " ")) {
      event.preventDefault();
      var info = this.itemOf(target);
      this.pick(this.picked === info.item.uid ? null : info.item.uid);
    } else if (target.tagName === "INPUT" && event.key === "Enter") {
      event.preventDefault();
    }
  };

  Editor.prototype.onInput = function (event, committed) {
    var target = event.target;
    var role = target.getAttribute("data-role");
    var info = this.itemOf(target);
    if (!role || !info) return;
    var item = info.item;
    if (target.tagName === "SELECT") {
      if (!committed) return;
      this.edit(function () {
        if (role === "scheme") this.setScheme(item, target.value);
        else if (role === "reward") { item.reward = target.value; item.params = {}; }
        else if (role === "leaf-reward") this.setLeafReward(item, target.value);
      });
      return;
    }
    // text, number and checkbox fields change the model in place (no redraw: focus and caret stay)
    if (!committed || target.type === "checkbox") {
      if (!this.editing || this.editing !== target) { this.remember(); this.editing = target; }
    }
    if (role === "scale") item.scale = numberOrRaw(target);
    else if (role === "board") item.board = target.value === "" ? 0 : numberOrRaw(target);
    else if (role === "label") item.name = target.value;
    else if (role === "leaf-scale" && item.own) item.own.scale = numberOrRaw(target);
    else if (role.indexOf("param-") === 0) this.setParam(item, target);
    else return;
    if (committed) this.editing = null;
    this.changed();
    this.paintVerification(); // not redrawn: the badges follow the text here
  };

  function numberOrRaw(input) {
    if (input.value === "") return input.value;
    var number = Number(input.value);
    return isFinite(number) ? number : input.value;
  }

  Editor.prototype.setScheme = function (node, scheme) {
    var functions = this.functionsOf(scheme);
    node.scheme = scheme;
    if (!this.functionOf(scheme, node.reward)) {
      node.reward = functions.length ? functions[0].name : undefined;
      node.params = {};
    }
  };

  Editor.prototype.setLeafReward = function (leaf, value) {
    if (!value) { leaf.own = null; return; }
    var parts = value.split("/");
    var scale = leaf.own ? leaf.own.scale : 1;
    var same = leaf.own && leaf.own.scheme === parts[0] && leaf.own.reward === parts[1];
    leaf.own = { scheme: parts[0], reward: parts[1], scale: scale, params: same ? leaf.own.params : {},
                 name: leaf.own ? leaf.own.name : "" };
  };

  Editor.prototype.setParam = function (item, input) {
    var name = input.getAttribute("data-param");
    var kind = input.getAttribute("data-kind");
    var params = item.params || (item.params = {});
    if (kind === "boolean") { params[name] = input.checked; return; }
    if (input.value === "") { delete params[name]; return; }
    if (kind === "number") params[name] = numberOrRaw(input);
    else if (kind === "json") {
      try { params[name] = JSON.parse(input.value); } catch (ignored) { params[name] = input.value; }
    } else params[name] = input.value;
  };

  Editor.prototype.addNode = function (node) {
    this.edit(function () {
      var added = { kind: "node", uid: nextUid++, scheme: "NL", reward: "none", scale: 1, params: {}, board: 0,
        name: "", children: [] };
      node.children.push(added);
      return [added.uid, "scheme"];
    });
  };

  Editor.prototype.duplicate = function (info) {
    if (!info.parent) return;
    this.edit(function () {
      var siblings = info.parent.children;
      var copy = cloneItem(info.item);
      siblings.splice(siblings.indexOf(info.item) + 1, 0, copy);
      return [copy.uid, "duplicate"];
    });
  };

  Editor.prototype.remove = function (info) {
    if (!info.parent) return;
    this.edit(function () {
      var siblings = info.parent.children;
      Array.prototype.splice.apply(siblings, [siblings.indexOf(info.item), 1].concat(info.item.children || []));
      return [info.parent.uid, "add-node"];
    });
  };

  /* May the item uid go into the node targetUid? Not a leaf target, not itself, not its own descendant. */
  Editor.prototype.canMove = function (uid, targetUid) {
    var moving = this.index[uid];
    var target = this.index[targetUid];
    if (!moving || !target || target.item.kind !== "node" || !moving.parent) return false;
    for (var at = target; at; at = at.parent ? this.index[at.parent.uid] : null) {
      if (at.item === moving.item) return false;
    }
    return true;
  };

  Editor.prototype.move = function (uid, targetUid) {
    if (!this.canMove(uid, targetUid)) { this.render(); return false; }
    var moving = this.index[uid];
    var target = this.index[targetUid].item;
    this.edit(function () {
      var siblings = moving.parent.children;
      siblings.splice(siblings.indexOf(moving.item), 1);
      target.children.push(moving.item);
      return [uid, moving.item.kind === "leaf" ? "leaf" : "grip"];
    });
    return true;
  };

  Editor.prototype.pick = function (uid) {
    this.picked = uid;
    this.render();
    if (uid !== null) {
      var first = this.treeArea.querySelector('[data-role="drop-here"]');
      if (first) first.focus();
    }
  };

  Editor.prototype.showPick = function () {
    var line = this.pickLine;
    if (this.picked === null || !this.index[this.picked]) {
      line.hidden = true;
      line.textContent = "";
      return;
    }
    var info = this.index[this.picked];
    var what = info.item.kind === "leaf" ? info.item.agent : "node " + info.path;
    line.hidden = false;
    line.textContent = "Moving " + what + ": choose \u201cMove here\u201d on the node it goes into (Escape cancels).";
  };

  // --- HTML5 drag and drop ---
  Editor.prototype.onDragStart = function (event) {
    var source = event.target.closest ? event.target.closest('[data-role="leaf"], [data-role="grip"]') : null;
    if (!source || event.target.closest("select, input")) { event.preventDefault(); return; }
    var info = this.itemOf(source);
    if (!info || !info.parent) { event.preventDefault(); return; }
    this.dragging = info.item.uid;
    var transfer = event.dataTransfer;
    transfer.effectAllowed = "move";
    try { transfer.setData("text/plain", String(info.item.uid)); } catch (ignored) { /* old browsers */ }
    if (info.item.kind === "node" && transfer.setDragImage) {
      var card = source.closest('[data-role="node"]');
      if (card) transfer.setDragImage(card, 12, 12);
    }
    var moving = source.getAttribute("data-role") === "leaf" ? source : source.closest('[data-role="node"]');
    if (moving) moving.classList.add("moving");
    this.treeArea.classList.add("dragging");
  };

  Editor.prototype.dropTarget = function (event) {
    var card = event.target.closest ? event.target.closest('[data-role="node"]') : null;
    if (!card || this.dragging === null) return null;
    var uid = Number(card.getAttribute("data-uid"));
    return this.canMove(this.dragging, uid) ? card : null;
  };

  Editor.prototype.onDragOver = function (event) {
    var card = this.dropTarget(event);
    this.highlight(card);
    if (!card) return;
    event.preventDefault();
    event.dataTransfer.dropEffect = "move";
  };

  Editor.prototype.onDragLeave = function (event) {
    if (!event.relatedTarget || !this.treeArea.contains(event.relatedTarget)) this.highlight(null);
  };

  Editor.prototype.highlight = function (card) {
    Array.prototype.forEach.call(this.treeArea.querySelectorAll(".drop-target"), function (node) {
      if (node !== card) node.classList.remove("drop-target");
    });
    if (card) card.classList.add("drop-target");
  };

  Editor.prototype.onDrop = function (event) {
    var card = this.dropTarget(event);
    if (!card) return;
    event.preventDefault();
    var uid = this.dragging;
    this.dragging = null;
    this.treeArea.classList.remove("dragging");
    this.move(uid, Number(card.getAttribute("data-uid")));
  };

  /* The drag ended without a drop (a drop redraws the tree): unmark what was dragged. */
  Editor.prototype.endDrag = function () {
    this.treeArea.classList.remove("dragging");
    this.highlight(null);
    if (this.dragging === null) return;
    var moving = this.treeArea.querySelector('[data-uid="' + this.dragging + '"]');
    if (moving && this.dragging !== this.picked) moving.classList.remove("moving");
    this.dragging = null;
  };

  // --- jobs: verify and preview ---
  /* what: verify, preview or save; its button is off while it runs (and for a visitor). */
  Editor.prototype.setBusy = function (what, busy) {
    this.busy[what] = busy;
    var button = { verify: this.verifyButton, preview: this.previewButton, save: this.saveButton }[what];
    button.disabled = busy || !this.signedIn;
    button.setAttribute("aria-busy", busy ? "true" : "false");
  };

  function progressText(what, view) {
    var text = what + ": " + view.state;
    if (view.progress && view.progress.total) text += " (" + view.progress.done + " / " + view.progress.total + ")";
    return text + "\u2026";
  }

  Editor.prototype.runJob = function (what, url, body) {
    var self = this;
    var label = what === "verify" ? "Verification" : "Preview";
    self.jobKind = what;
    self.setBusy(what, true);
    setStatus(self.jobLine, "queued", label + ": queued\u2026");
    return request("POST", url, body).then(function (queued) {
      return window.Arena.watchJob(queued.job, function (view) {
        if (!view.finished) setStatus(self.jobLine, view.state, progressText(label, view));
      }).then(function (view) {
        if (view.state !== "done") {
          throw new Error(view.error || ("the job ended " + view.state));
        }
        return { job: queued.job, result: view.result };
      });
    }).then(function (done) {
      self.setBusy(what, false);
      return done;
    }, function (error) {
      self.setBusy(what, false);
      setStatus(self.jobLine, "failed", label + " failed: " + messageOf(error));
      throw error;
    });
  };

  Editor.prototype.seed = function () {
    var seed = parseInt(this.seedInput.value, 10);
    return isFinite(seed) && seed >= 0 ? seed : 0;
  };

  Editor.prototype.runVerify = function () {
    var self = this;
    if (!self.signedIn || self.busy.verify) return;
    var text = self.text;
    var samples = parseInt(self.samplesInput.value, 10);
    if (!isFinite(samples)) samples = 64;
    self.runJob("verify", "/api/trees/verify", { game: self.game, spec: self.spec, samples: samples,
      seed: self.seed() }).then(function (done) {
      self.verified = { spec: text, result: done.result };
      var nodes = (done.result && done.result.nodes) || [];
      var off = nodes.filter(function (node) { return !node.ok; }).length;
      setStatus(self.jobLine, "done", off
        ? "Verified: " + off + " of " + nodes.length + " nodes do not behave as declared (marked below)."
        : "Verified: every node (" + nodes.length + ") behaves as its declared scheme.");
      self.paintVerification();
      self.markStale(); // edited while it ran
    }, function () { /* shown by runJob */ });
  };

  /* Paint each card with its verdict when the tree is the one verified. */
  Editor.prototype.paintVerification = function () {
    var self = this;
    var badges = self.treeArea.querySelectorAll('[data-role="verified"]');
    Array.prototype.forEach.call(badges, function (badge) {
      badge.hidden = true;
      badge.textContent = "";
      var owner = badge.closest("[data-uid]");
      if (owner) owner.classList.remove("verified-ok", "verified-mismatch");
    });
    var current = self.verified && self.verified.spec === self.text;
    self.root.setAttribute("data-verified", current ? "yes" : "no");
    if (!current) return;
    ((self.verified.result && self.verified.result.nodes) || []).forEach(function (verdict) {
      var target = self.findPath(verdict.path);
      if (!target) return;
      var badge = null;
      Array.prototype.forEach.call(target.querySelectorAll('[data-role="verified"]'), function (candidate) {
        if (!badge && candidate.closest("[data-uid]") === target) badge = candidate;
      });
      if (!badge) return;
      badge.textContent = "";
      badge.appendChild(el("span", { "class": "verdict-mark", "aria-hidden": "true" }, verdict.ok ? "\u2713" : "\u2717"));
      badge.appendChild(document.createTextNode(" declared " + verdict.declared + " \u00b7 verified "));
      badge.appendChild(el("strong", { "data-role": "verified-scheme" }, verdict.verified));
      if (!verdict.ok) badge.appendChild(document.createTextNode(" (does not match)"));
      badge.title = "learnable in " + Math.round((verdict.learnable_share || 0) * 100) + "% of " + verdict.pairs +
        " sampled pairs";
      badge.hidden = false;
      target.classList.add(verdict.ok ? "verified-ok" : "verified-mismatch");
    });
  };

  /* After an edit, a verification shown in the job line no longer describes the tree. */
  Editor.prototype.markStale = function () {
    var verifiedNow = this.verified && this.verified.spec === this.text;
    if (this.jobKind === "verify" && this.jobLine.getAttribute("data-state") === "done" && !verifiedNow) {
      setStatus(this.jobLine, "stale",
        "The tree changed since it was verified; verify again to see its nodes' schemes.");
    }
  };

  Editor.prototype.runPreview = function () {
    var self = this;
    if (!self.signedIn || self.busy.preview) return;
    self.runJob("preview", "/api/trees/preview", { game: self.game, spec: self.spec, seed: self.seed() })
      .then(function (done) {
        setStatus(self.jobLine, "done", "Preview ready: one match of the scripted players under this tree, below.");
        self.showPreview(done.result);
      }, function () { /* shown by runJob */ });
  };

  Editor.prototype.showPreview = function (result) {
    var self = this;
    var area = self.previewArea;
    if (window.ArenaReplay) { // stop an earlier preview
      Array.prototype.forEach.call(area.querySelectorAll(".replay-player"), window.ArenaReplay.unmount);
    }
    area.textContent = "";
    area.hidden = false;
    area.appendChild(el("h2", {}, "Preview"));
    area.appendChild(el("p", { "class": "meta", "data-role": "preview-summary" },
      result.steps + " steps; outcomes " + (result.outcomes || []).join(", ") + "; scores " +
      (result.scores || []).join(", ") + "."));
    var table = el("table", { "class": "data tree-rewards" }, [
      el("thead", {}, el("tr", {}, [el("th", {}, "agent"), el("th", {}, "team"),
        el("th", {}, "summed reward under this tree")]))]);
    var body = el("tbody");
    self.catalog.agents.forEach(function (agent, seat) {
      var team = self.catalog.teams[seat];
      var value = (result.rewards || [])[seat];
      var name = el("td", { "class": "name" }, el("span", { "class": "tree-swatch",
        style: "background:" + self.colourOf(team) }, agent));
      body.appendChild(el("tr", {}, [name, el("td", {}, String(team)),
        el("td", { "class": "num" }, value === undefined ? "" : String(value))]));
    });
    table.appendChild(body);
    area.appendChild(table);
    var player = el("div", { "class": "replay-player", "data-src": result.replay });
    area.appendChild(player);
    if (window.ArenaReplay && window.ArenaReplay.mount) window.ArenaReplay.mount(player);
    else player.appendChild(el("p", { "class": "reason" }, "The replay player did not load; the replay is at " +
      result.replay));
    if (area.scrollIntoView) area.scrollIntoView({ behavior: "smooth", block: "start" });
  };

  // --- saving ---
  Editor.prototype.save = function () {
    var self = this;
    if (!self.signedIn || self.busy.save) return;
    var name = self.nameInput.value.trim();
    if (!TREE_NAME.test(name)) {
      setStatus(self.savedArea, "error", name ? "A tree name is 1 to 64 letters, digits, spaces and . _ -, " +
        "starting with a letter or digit." : "Give the tree a name to save it.");
      self.nameInput.focus();
      return;
    }
    self.setBusy("save", true);
    setStatus(self.savedArea, "pending", "Saving\u2026");
    request("POST", "/api/trees", { name: name, game: self.game, spec: self.spec }).then(function (view) {
      self.showSaved(view, false);
    }, function (error) {
      setStatus(self.savedArea, "error", "Not saved: " + messageOf(error));
    }).then(function () {
      self.setBusy("save", false);
    });
  };

  Editor.prototype.showSaved = function (view, loaded) {
    var base = "/api/trees/" + view.id + "/download?format=";
    this.savedArea.setAttribute("data-tree", view.id);
    setStatus(this.savedArea, "saved", [loaded ? "Opened " : "Saved as ",
      el("a", { href: "/trees/" + view.id, "data-role": "tree-link" }, view.name),
      loaded ? " (saved by " + view.owner + "). Files: " : ". Files: ",
      el("a", { href: base + "yaml", "data-role": "download-yaml", download: "tree-" + view.id + ".yaml" }, "YAML"),
      " \u00b7 ",
      el("a", { href: base + "json", "data-role": "download-json", download: "tree-" + view.id + ".json" }, "JSON"),
      " \u2014 for make(\"" + view.game_id + "\", tree=\"tree-" + view.id + ".yaml\") or arena-league verify --tree " +
        "tree-" + view.id + ".yaml"]);
  };

  function start() {
    var root = document.getElementById("tree-editor");
    if (!root || root.__treeEditor) return;
    root.__treeEditor = new Editor(root);
    root.__treeEditor.start();
  }

  if (document.readyState === "loading") document.addEventListener("DOMContentLoaded", start);
  else start();
})();
