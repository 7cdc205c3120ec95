// Headless screenshot of the Studio web app with the system chromium.
// Usage: node shot.mjs <url> [out.png] [settleMs]
//   Waits for the page "load", then until the playback bar's Play button is enabled (player present) and the
//   remote-file reader logged "Connection ... finished!" (max +15 s), aborting on a "Player problem" or after
//   LOAD_TIMEOUT_MS (default 120000); then settleMs (default 5000) so panels can render; then a 1600x1000 PNG.
//   Exit code 0 = data loaded, 2 = not ready (screenshot is still written, for diagnosis).
import puppeteer from "puppeteer-core";
const [url, out = "shot.png", settleMs = "5000"] = process.argv.slice(2);
const browser = await puppeteer.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  headless: true,
  // SwiftShader (software WebGL) — needed for the 3D panel on a machine without GPU
  args: ["--no-sandbox", "--disable-dev-shm-usage", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--ignore-gpu-blocklist", "--window-size=1600,1000"],
  defaultViewport: { width: 1600, height: 1000 },
  protocolTimeout: 240000,
});
const page = await browser.newPage();
let loadedResolve; const loaded = new Promise((r) => (loadedResolve = r));
const problems = [];
let problemResolve; const problem = new Promise((r) => (problemResolve = r));
page.on("console", (m) => {
  const t = m.text();
  if (/Connection .* finished!/.test(t)) loadedResolve();
  if (/Player problem/.test(t)) setTimeout(problemResolve, 1000);
  if (m.type() === "error" && !/favicon|status of 404/.test(t)) problems.push(t);
  if (!/identical config/.test(t)) console.log(`[console.${m.type()}]`, t.slice(0, 300));
  if (/\[object Object\]/.test(t) && !/identical config/.test(t)) // e.g. "Player problem global-error [object Object]": print the object
    Promise.all(m.args().map((a) => a.jsonValue().catch(() => "?"))).then((v) => console.log("   details:", JSON.stringify(v).slice(0, 800)));
});
page.on("pageerror", (e) => { problems.push(String(e)); console.log("[pageerror]", String(e).slice(0, 300)); });
page.on("response", (r) => { if (r.status() >= 400 && !r.url().endsWith("favicon.ico")) console.log("[http " + r.status() + "]", r.url()); });
const t0 = Date.now();
await page.goto(url, { waitUntil: "load", timeout: 180000 });
console.log("page load event after", Date.now() - t0, "ms");
// ready = the Play button of the playback bar is enabled (player present) AND the remote reader logged
// "Connection ... finished!" (whole file fetched); a "Player problem" aborts the wait.
const ready = page.waitForFunction(() => {
  const b = document.querySelector('button[title="Play"], button[title="Pause"]');
  return b != null && !b.disabled;
}, { timeout: 0, polling: 500 })
  // big files are read in ranges on demand and may never log "finished": give it at most 15 s more
  .then(() => Promise.race([loaded, new Promise((r) => setTimeout(r, 15000))])).then(() => true);
const ok = await Promise.race([ready, problem.then(() => false),
  new Promise((r) => setTimeout(() => r(false), Number(process.env.LOAD_TIMEOUT_MS ?? 120000)))]);
console.log(ok ? "player ready, data loaded" : "WARNING: not ready (player problem or LOAD_TIMEOUT_MS, default 120 s)", "after", Date.now() - t0, "ms");
await new Promise((r) => setTimeout(r, Number(settleMs)));
await page.screenshot({ path: out });
console.log("screenshot", out, "after", Date.now() - t0, "ms;", problems.length, "console errors");
await browser.close();
process.exit(ok ? 0 : 2);
