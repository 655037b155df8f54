// bowlrec's pages: a little JavaScript on server-rendered HTML. Every request goes to this
// server with the browser's cookie session (same origin); nothing is loaded from elsewhere.
"use strict";

async function postJson(url, body) {
  const response = await fetch(url, {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: body === undefined ? undefined : JSON.stringify(body),
    credentials: "same-origin",
  });
  let data = null;
  try { data = await response.json(); } catch (e) { data = null; }
  if (!response.ok) {
    const detail = data && data.detail ? data.detail : response.status + " " + response.statusText;
    throw new Error(detail);
  }
  return data;
}

function showError(element, message) {
  element.textContent = message;
  element.hidden = false;
}

function initSignin() {
  const form = document.getElementById("signin");
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    try {
      await postJson("/session", { token: form.elements.token.value });
      window.location.reload();
    } catch (e) {
      showError(form.querySelector(".error"), e.message);
    }
  });
}

function initRuns() {
  const button = document.getElementById("compare-button");
  if (!button) return;
  const boxes = () => document.querySelectorAll('input[name="ids"][form="compare"]');
  const update = () => {
    const n = Array.from(boxes()).filter((b) => b.checked).length;
    button.disabled = n < 1;
    button.textContent = n > 0 ? "Compare selected (" + n + ")" : "Compare selected";
  };
  boxes().forEach((b) => b.addEventListener("change", update));
  update();
}

function initJobs() {
  const form = document.getElementById("submit-form");
  const editor = document.getElementById("editor");
  const seed = document.getElementById("seed");
  const texts = document.querySelectorAll("template.seed-text");
  const error = document.getElementById("submit-error");
  seed.addEventListener("change", () => {
    editor.value = texts[Number(seed.value)].content.textContent;
    const kind = seed.options[seed.selectedIndex].dataset.kind;
    form.querySelector('input[value="' + kind + '"]').checked = true;
  });
  form.addEventListener("submit", async (event) => {
    event.preventDefault();
    error.hidden = true;
    let body;
    try {
      body = JSON.parse(editor.value);
    } catch (e) {
      showError(error, "not valid JSON: " + e.message);
      return;
    }
    const kind = form.querySelector('input[name="kind"]:checked').value;
    try {
      if (kind === "job") {
        const job = await postJson("/jobs", body);
        window.location.href = "/ui/jobs/" + job.job_id;
      } else {
        const run = await postJson("/runs", body);
        window.location.href = "/ui/runs/" + run.run_id;
      }
    } catch (e) {
      showError(error, e.message);
    }
  });
}

function cell(row, text, numeric) {
  const td = document.createElement("td");
  td.textContent = text;
  if (numeric) td.className = "num";
  row.appendChild(td);
  return td;
}

function fixed(value, scale, digits) {
  return value === null || value === undefined ? "" : (value * scale).toFixed(digits);
}

async function loadResults(jobId) {
  const section = document.getElementById("results");
  const table = document.getElementById("results-table");
  const axes = JSON.parse(table.dataset.axes);
  const response = await fetch("/jobs/" + jobId + "/results?limit=500", { credentials: "same-origin" });
  if (!response.ok) return;
  const rows = await response.json();
  const head = document.createElement("tr");
  ["#", "run", ...axes, "outcome", "hook (cm, +left)", "pocket (deg, +left)", "slide (m)"].forEach((h) => {
    const th = document.createElement("th");
    th.textContent = h;
    head.appendChild(th);
  });
  table.tHead.replaceChildren(head);
  const body = table.tBodies[0];
  body.replaceChildren();
  rows.forEach((r) => {
    const tr = document.createElement("tr");
    cell(tr, String(r.index), true);
    const link = document.createElement("a");
    if (r.run_id) {
      link.href = "/ui/runs/" + r.run_id;
      link.textContent = r.run_id.slice(0, 12);
      link.className = "mono";
    }
    cell(tr, "", false).appendChild(link);
    axes.forEach((a) => cell(tr, r.values[a] === undefined ? "" : String(r.values[a]), true));
    cell(tr, r.outcome || "", false);
    cell(tr, fixed(r.hook_m, 100, 2), true);
    cell(tr, fixed(r.pocket_deg, 1, 2), true);
    cell(tr, fixed(r.slide_m, 1, 3), true);
    body.appendChild(tr);
  });
  document.getElementById("results-note").textContent =
    rows.length === 500 ? "The first 500 runs; GET /jobs/" + jobId + "/results?limit=5000 gives more." : "";
  section.hidden = false;
  const plot = document.getElementById("plot-form");
  if (plot) {
    const draw = () => {
      const q = new URLSearchParams(new FormData(plot));
      document.getElementById("job-figure").src = "/jobs/" + jobId + "/figure.svg?" + q.toString();
    };
    plot.addEventListener("change", draw);
    draw();
  }
}

function initJob() {
  const box = document.getElementById("job");
  const jobId = box.dataset.job;
  const statusEl = document.getElementById("job-status");
  const counts = document.getElementById("job-counts");
  const bar = document.getElementById("job-progress");
  const errorEl = document.getElementById("job-error");
  const cancel = document.getElementById("cancel-job");
  const final = ["done", "failed", "cancelled", "interrupted", "damaged"];
  const show = (s) => {
    statusEl.textContent = s.status;
    statusEl.className = "status " + s.status;
    counts.textContent = s.done + " done, " + s.failed + " failed of " + s.total + " runs";
    bar.max = s.total;
    bar.value = s.done + s.failed;
    if (s.error) showError(errorEl, s.error);
    if (cancel) cancel.hidden = final.includes(s.status); // none for a command-line job
  };
  if (cancel) {
    cancel.addEventListener("click", async () => {
      try { show(await postJson("/jobs/" + jobId + "/cancel")); } catch (e) { showError(errorEl, e.message); }
    });
  }
  if (final.includes(box.dataset.status)) {
    loadResults(jobId);
    return;
  }
  const events = new EventSource("/jobs/" + jobId + "/events");
  events.onmessage = (message) => {
    const s = JSON.parse(message.data);
    show(s);
    if (final.includes(s.status)) {
      events.close();
      box.dataset.status = s.status;
      loadResults(jobId);
    }
  };
  events.onerror = () => {
    if (!final.includes(box.dataset.status)) {
      events.close();
      setTimeout(() => window.location.reload(), 2000);
    }
  };
}

function initBalls() {
  const form = document.getElementById("layout-form");
  if (!form) return;
  form.addEventListener("change", () => {
    const q = new URLSearchParams(new FormData(form)).toString();
    document.querySelectorAll("img.layout").forEach((img) => {
      img.src = "/balls/" + encodeURIComponent(img.dataset.ref) + "/figure.svg?" + q;
    });
  });
}

// -- the pin deck of a run with pin action: drawn from GET /runs/{id}/pins ----------------------

const SVG_NS = "http://www.w3.org/2000/svg";

function svgEl(parent, name, attrs, cls) {
  const el = document.createElementNS(SVG_NS, name);
  Object.entries(attrs || {}).forEach(([k, v]) => el.setAttribute(k, String(v)));
  if (cls) el.setAttribute("class", cls);
  if (parent) parent.appendChild(el);
  return el;
}

function kvRow(table, label, value) {
  const tr = document.createElement("tr");
  const th = document.createElement("th");
  th.textContent = label;
  const td = document.createElement("td");
  td.textContent = value;
  tr.append(th, td);
  table.appendChild(tr);
}

// The deck seen from above with the head pin nearest the bowler (at the bottom) and the
// bowler's left (+y) on the left: the SVG's user units are metres, X = yMax - y, Y = xMax - x.
function drawDeck(section, data) {
  const deck = data.deck;
  const svg = document.getElementById("deck-svg");
  const gutter = 0.235;
  const yMin = -gutter, yMax = deck.width_m + gutter;
  const xMin = deck.x0_m - 0.25, xMax = deck.x1_m + 0.5;
  const X = (y) => yMax - y;
  const Y = (x) => xMax - x;
  svg.setAttribute("viewBox", "0 0 " + (yMax - yMin).toFixed(4) + " " + (xMax - xMin).toFixed(4));
  svg.replaceChildren();
  svgEl(svg, "rect", { x: 0, y: 0, width: yMax - yMin, height: xMax - xMin }, "deck-pit");
  svgEl(svg, "rect", { x: 0, y: Y(deck.x1_m), width: yMax - yMin, height: deck.x1_m - xMin }, "deck-gutter");
  svgEl(svg, "rect", { x: X(deck.width_m), y: Y(deck.x0_m), width: deck.width_m, height: deck.x0_m - xMin }, "deck-lane");
  svgEl(svg, "rect", { x: X(deck.width_m), y: Y(deck.x1_m), width: deck.width_m, height: deck.x1_m - deck.x0_m }, "deck-deck");
  Object.entries(deck.spots).forEach(([pin, [x, y]]) => {
    svgEl(svg, "circle", { cx: X(y), cy: Y(x), r: 0.0143 }, "deck-spot");
    const label = svgEl(svg, "text", { x: X(y), y: Y(x) + 0.1 }, "deck-spot-label");
    label.textContent = pin;
  });
  const points = (xy) => xy.map(([x, y]) => X(y).toFixed(4) + "," + Y(x).toFixed(4)).join(" ");
  if (data.approach.length > 1) svgEl(svg, "polyline", { points: points(data.approach) }, "deck-approach");
  svgEl(svg, "polyline", { points: points(data.ball) }, "deck-path");
  if (data.exit_y_m !== null && data.exit_y_m !== undefined) {
    const ex = X(data.exit_y_m), ey = Y(deck.x1_m);
    svgEl(svg, "polygon", { points: [ex - 0.03, ey - 0.04, ex + 0.03, ey - 0.04, ex, ey].join(" ") }, "deck-exit");
  }
  const touched = new Set(data.touched);
  const pins = data.pins.map((p) => {
    const g = svgEl(svg, "g", { "data-pin": p.pin }, "pin" + (touched.has(p.pin) ? " touched" : ""));
    const body = svgEl(g, "line", { "stroke-width": 2 * deck.pin_radius_m }, "pin-body");
    const head = svgEl(g, "circle", { r: 0.032 }, "pin-head");
    const disc = svgEl(g, "circle", { r: deck.pin_radius_m }, "pin-disc");
    const label = svgEl(g, "text", {}, "pin-label");
    label.textContent = String(p.pin);
    return { data: p, g, body, head, disc, label };
  });
  const ball = svgEl(svg, "circle", { r: deck.ball_radius_m }, "deck-ball");
  const standingAtEnd = new Set(data.standing);
  const last = data.t_s.length - 1;
  // a pin leaning less than the engine's 15 degrees stands (its axis seen from above is short)
  const upright = deck.pin_height_m * Math.sin((15 * Math.PI) / 180);
  const show = (i) => {
    pins.forEach((p) => {
      const [bx, by] = p.data.base[i];
      const [hx, hy] = p.data.head[i];
      const stands = i === last ? standingAtEnd.has(p.data.pin) : Math.hypot(hx - bx, hy - by) < upright;
      // the axis drawn from the belly's centre outward, so a lying pin covers its length
      const f = 0.3;
      const [cx, cy] = [bx + f * (hx - bx), by + f * (hy - by)];
      p.body.setAttribute("x1", X(by).toFixed(4));
      p.body.setAttribute("y1", Y(bx).toFixed(4));
      p.body.setAttribute("x2", X(hy).toFixed(4));
      p.body.setAttribute("y2", Y(hx).toFixed(4));
      p.head.setAttribute("cx", X(hy).toFixed(4));
      p.head.setAttribute("cy", Y(hx).toFixed(4));
      p.disc.setAttribute("cx", X(by).toFixed(4));
      p.disc.setAttribute("cy", Y(bx).toFixed(4));
      p.label.setAttribute("x", (stands ? X(by) : X(cy)).toFixed(4));
      p.label.setAttribute("y", (stands ? Y(bx) : Y(cx)).toFixed(4));
      p.g.classList.toggle("standing", stands);
      p.g.classList.toggle("down", !stands);
      p.g.classList.toggle("pit", p.data.in_pit[i] === 1);
    });
    const [x, y] = data.ball[i];
    ball.setAttribute("cx", X(y).toFixed(4));
    ball.setAttribute("cy", Y(x).toFixed(4));
    section.dataset.frame = String(i);
    section.dataset.standing = String(pins.filter((p) => p.g.classList.contains("standing")).length);
  };
  return { show, last };
}

async function initRun() {
  const section = document.getElementById("pin-deck");
  if (!section) return;
  const note = document.getElementById("pin-note");
  const response = await fetch("/runs/" + section.dataset.run + "/pins", { credentials: "same-origin" });
  if (!response.ok) {
    showError(note, "The pins could not be loaded: " + response.status + " " + response.statusText);
    return;
  }
  const data = await response.json();
  if (data === null) {
    note.textContent = "This run's stored trajectory holds no pin action.";
    note.hidden = false;
    return;
  }
  document.getElementById("pin-leave").textContent = data.leave;
  const table = document.getElementById("pin-result");
  const boards = (v, signed) => (v === null ? "–" : (signed && v > 0 ? "+" : "") + v.toFixed(1));
  kvRow(table, "leave", data.leave);
  kvRow(table, "pinfall", data.pinfall + " of " + data.set_pins.length);
  kvRow(table, "standing", data.standing.length ? data.standing.join(", ") : "none");
  kvRow(table, "touched by the ball", data.touched.length ? data.touched.join("-") : "none");
  kvRow(table, "exit board", boards(data.exit_board, false));
  kvRow(table, "deflection (boards)", boards(data.deflection_boards, true));
  kvRow(table, "hand", data.hand);
  if (data.time_s !== null) kvRow(table, "pin action (s)", data.time_s.toFixed(3) + (data.at_rest ? ", at rest" : ", time limit"));
  const slider = document.getElementById("deck-time");
  const play = document.getElementById("deck-play");
  const clock = document.getElementById("deck-clock");
  if (!data.t_s.length) {
    note.textContent = "The ball did not reach the pins.";
    note.hidden = false;
    play.disabled = true;
    slider.disabled = true;
    return;
  }
  const view = drawDeck(section, data);
  const show = (i) => {
    view.show(i);
    slider.value = String(i);
    clock.textContent = "t = " + data.t_s[i].toFixed(3) + " s after the hand-off";
  };
  slider.max = String(view.last);
  show(view.last);
  section.dataset.ready = "1";
  let playing = null;
  const stop = () => {
    if (playing !== null) cancelAnimationFrame(playing);
    playing = null;
    play.textContent = "Play";
  };
  slider.addEventListener("input", () => {
    stop();
    show(Number(slider.value));
  });
  play.addEventListener("click", () => {
    if (playing !== null) {
      stop();
      return;
    }
    const from = Number(slider.value) >= view.last ? 0 : Number(slider.value);
    const t0 = performance.now() / 1000 - data.t_s[from];
    play.textContent = "Pause";
    const step = () => {
      const t = performance.now() / 1000 - t0;
      let i = from;
      while (i < view.last && data.t_s[i + 1] <= t) i++;
      show(i);
      if (i >= view.last) stop();
      else playing = requestAnimationFrame(step);
    };
    playing = requestAnimationFrame(step);
  });
}

const INIT = { signin: initSignin, runs: initRuns, run: initRun, jobs: initJobs, job: initJob, balls: initBalls };
document.addEventListener("DOMContentLoaded", () => {
  const init = INIT[document.body.dataset.page];
  if (init) init();
});
