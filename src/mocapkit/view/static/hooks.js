// Loaded first (a classic script): the page's error log and the test hooks object, so that errors
// raised while the modules load are recorded too. viewer.js fills in the rest of window.mocapkitView.
"use strict";
window.mocapkitView = { ready: false, frames: 0, errors: [] };
window.addEventListener("error", (event) => {
  window.mocapkitView.errors.push(String(event.message || event.error || "error"));
});
window.addEventListener("unhandledrejection", (event) => {
  const r = event.reason;
  window.mocapkitView.errors.push(String((r && r.stack) || r));
});
