// The setup form (built from the server's fields, each with the methods that ask it)
// and the setup line that keeps what is recorded in view.
"use strict";

function buildSetup(fields) {
  const box = $("setup-fields");
  box.replaceChildren();
  for (const f of fields) {
    const cell = el("div", null, "cell" + (f.kind === "check" ? " check" : ""));
    cell.id = "cell-" + f.name;
    cell.dataset.methods = f.methods.join(" ");
    let input;
    if (f.kind === "choice") {
      input = el("select");
      if (!f.value) {
        const choose = el("option", "choose...");
        choose.value = "";
        input.append(choose);
      }
      for (const option of f.options) {
        const o = el("option", option);
        o.value = option;
        input.append(o);
      }
      input.value = f.value || "";
      input.disabled = f.given;
    } else if (f.kind === "check") {
      input = el("input");
      input.type = "checkbox";
      input.checked = ["y", "yes", "true", "on", "1"].includes(String(f.value).toLowerCase());
      input.disabled = f.given;
    } else {
      input = el("input");
      input.type = "text";
      input.autocomplete = "off";
      input.value = f.value || "";
      input.readOnly = f.given;
    }
    input.id = "f-" + f.name;
    input.dataset.testid = "field-" + f.name;
    input.name = f.name;
    const defaults = Object.values(f.unit_defaults || {});
    if (new Set(defaults).size > 1) input.dataset.unitDefaults = JSON.stringify(f.unit_defaults);
    const name = el("label", f.label, "name");
    name.htmlFor = input.id;
    if (f.kind === "check") cell.append(input, name);
    else cell.append(name, input);
    if (f.given) {
      // Where a fixed value comes from: the command line, or the continued session's file.
      const from = f.from || "the command line";
      const said = from === "the command line" ? "from the command line (fixed for this session)"
        : "from " + from + " (the session's setup, fixed)";
      const note = el("span", said, "note given");
      note.dataset.testid = "from-" + f.name;
      cell.append(note);
    } else if (f.from) {
      // Filled in from the continued session, but this file's own to change.
      const whose = f.name === "operator" ? "operator" : "stop rule";
      const note = el("span", "from " + f.from + ": its " + whose + "; this file's own, change it if it differs", "note given");
      note.dataset.testid = "from-" + f.name;
      cell.append(note);
    } else if (f.value && f.kind === "text") {
      // A default (the thesis' rig), said beside its value only: once changed, the field
      // holds the operator's.
      const note = el("span", "the thesis' rig: change it if yours differs", "note");
      note.id = "default-" + f.name;
      note.dataset.default = f.value;
      cell.append(note);
      input.addEventListener("input", () => show(note, input.value.trim() === note.dataset.default));
    }
    const error = el("span", "", "field-error hidden");
    error.id = "error-" + f.name;
    error.dataset.testid = "field-error-" + f.name;
    error.setAttribute("role", "alert");
    cell.append(error);
    box.append(cell);
  }
  const method = $("f-method");
  if (method) method.addEventListener("change", applyMethod);
  const units = $("f-units");
  if (units) units.addEventListener("change", applyUnits);
  applyMethod();
  setupBuilt = true;
}

function applyMethod() {
  // The chosen method's fields only; before one is chosen, those every method has.
  const method = $("f-method") ? $("f-method").value : "";
  const all = $("f-method") ? $("f-method").options.length - ($("f-method").options[0].value ? 0 : 1) : 0;
  for (const cell of $("setup-fields").children) {
    const methods = cell.dataset.methods.split(" ");
    show(cell, method ? methods.includes(method) : methods.length >= all);
  }
}

function applyUnits() {
  // A default that depends on the units follows them (the thesis' ground height is in
  // inches: offered for inches only, never converted); a value the operator typed stays.
  const units = $("f-units").value;
  for (const input of $("setup-fields").querySelectorAll("input[data-unit-defaults]")) {
    if (input.readOnly) continue;
    const defaults = JSON.parse(input.dataset.unitDefaults);
    if (!input.value || Object.values(defaults).includes(input.value)) input.value = defaults[units] || "";
    const note = $("default-" + input.name);
    if (note) show(note, input.value.trim() === note.dataset.default);
  }
}

function clearErrors(names) {
  for (const name of names) {
    const error = $("error-" + name);
    if (error) {
      setText(error, "");
      show(error, false);
    }
    const input = name in POSE_INPUTS ? $(POSE_INPUTS[name]) : $("f-" + name);
    if (input) input.classList.remove("invalid");
  }
}

function showErrors(errors, inputOf) {
  // Each refusal next to its field; returns the ones that have no field shown.
  const left = [];
  for (const [name, message] of Object.entries(errors)) {
    const error = $("error-" + name);
    const input = inputOf(name);
    if (error && input && input.getClientRects().length) {
      setText(error, message);
      show(error, true);
      input.classList.add("invalid");
    } else {
      left.push(message);
    }
  }
  return left;
}

async function submitSetup() {
  if (!state || state.phase !== "setup") return;
  const form = {};
  const names = [];
  for (const input of $("setup-fields").querySelectorAll("input, select")) {
    names.push(input.name);
    const visible = input.getClientRects().length > 0;
    if (input.type === "checkbox") form[input.name] = visible && input.checked ? "yes" : "";
    else form[input.name] = visible ? input.value.trim() : "";
  }
  clearErrors(names);
  show($("setup-refusal"), false);
  const answer = await post("/api/setup", form);
  if (answer.ok) return;
  const left = showErrors(answer.errors, (name) => $("f-" + name));
  if (left.length || !Object.keys(answer.errors).length) {
    setText($("setup-refusal"), left.length ? left.join("; ") : answer.error);
    show($("setup-refusal"), true);
  }
}

// The setup line's entries, named by their keys (these few by their words).
const SETUP_WORDS = {truth: "ground truth", stop_rule: "stop rule"};

function setupPart(name, value, units) {
  // One entry of the setup line, [name, value], or null when there is nothing to say.
  if (value === null || value === undefined || value === "") return null;
  if (Array.isArray(value)) {
    // The typed ground truth: its points, or none.
    const points = value.map((p) => "(" + p.map((v) => num(v)).join(", ") + ")");
    return [SETUP_WORDS[name] || name, points.length ? points.join(" to ") + " " + units : "none typed"];
  }
  if (typeof value === "object") return [value.words, num(value.offset) + " " + units]; // a plane's offset
  if (typeof value === "number") return [name.replace(/_/g, " "), num(value) + " " + units];
  return [SETUP_WORDS[name] || name.replace(/_/g, " "), value];
}

function renderSetupSummary(s) {
  // What is being recorded stays in view, in the server's order: method, units, camera,
  // ground truth (or the board), ...
  const shown = s.setup || {};
  if (!changed("setup-summary", shown)) return;
  const box = $("session-setup");
  show(box, !!shown.method);
  if (!shown.method) return;
  const parts = Object.entries(shown).map(([name, value]) => setupPart(name, value, shown.units));
  const children = [];
  parts.filter((p) => p).forEach(([name, value], i) => {
    if (i) children.push(document.createTextNode(" · "));
    children.push(el("span", name + " "), el("b", value));
  });
  box.replaceChildren(...children);
}
