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
  ["#", "run", ...axes, "outcome", "hook (cm)", "pocket (deg)", "slide (m)"].forEach((h) => {
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
    cancel.hidden = final.includes(s.status);
  };
  cancel.addEventListener("click", async () => {
    try { show(await postJson("/jobs/" + jobId + "/cancel")); } catch (e) { showError(errorEl, e.message); }
  });
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

const INIT = { signin: initSignin, runs: initRuns, jobs: initJobs, job: initJob, balls: initBalls };
document.addEventListener("DOMContentLoaded", () => {
  const init = INIT[document.body.dataset.page];
  if (init) init();
});
