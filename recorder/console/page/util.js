// The console's shared helpers (recorder/console/page/index.html loads the page's scripts in order:
// this one, setup.js, capture.js, topview.js, stream.js, then main.js,
// which polls and wires the controls). Every text goes in by textContent; the page never
// builds HTML from data.
"use strict";

const $ = (id) => document.getElementById(id);
const drawn = {}; // what each part of the page was last drawn from (JSON), to redraw on change

function el(tag, text, className) {
  const e = document.createElement(tag);
  if (text !== undefined && text !== null) e.textContent = String(text);
  if (className) e.className = className;
  return e;
}

function show(element, visible) {
  element.classList.toggle("hidden", !visible);
}

function setText(element, text) {
  const value = text === undefined || text === null ? "" : String(text);
  if (element.textContent !== value) element.textContent = value;
}

function changed(part, value) {
  const key = JSON.stringify(value);
  if (drawn[part] === key) return false;
  drawn[part] = key;
  return true;
}

function num(v, digits = 3) {
  // A number as the server sent it, as text (a value as the operator gave it), is shown as is.
  if (typeof v === "string") return v;
  if (v === null || v === undefined || !Number.isFinite(v)) return "–";
  return String(Number(v.toFixed(digits)));
}

function fixed(v, digits) {
  return v === null || v === undefined || !Number.isFinite(v) ? "–" : v.toFixed(digits);
}

async function post(path, body) {
  let response;
  let answer = {};
  try {
    response = await fetch(path, {
      method: "POST",
      headers: {"Content-Type": "application/json"},
      body: JSON.stringify(body),
      credentials: "same-origin",
      cache: "no-store",
    });
  } catch (err) {
    return {ok: false, error: "the recorder cannot be reached (" + err.message + ")", errors: {}};
  }
  try {
    answer = await response.json();
  } catch (err) {
    answer = {};
  }
  if (response.ok) return {ok: true, errors: {}};
  const error = typeof answer.error === "string" && answer.error
    ? answer.error : "refused by the recorder (HTTP " + response.status + ")";
  const errors = answer.errors && typeof answer.errors === "object" ? answer.errors : {};
  return {ok: false, error, errors};
}
