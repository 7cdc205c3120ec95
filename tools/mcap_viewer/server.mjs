// A static server with HTTP Range and CORS (Studio's remote-file source reads an MCAP with Range
// requests). Usage: node server.mjs PORT DATA_DIR. Routes: /assets/* the studio-base bundle,
// /vendor/* React 17 (UMD), /data/* DATA_DIR (the MCAP files), /layouts/* ./layouts, else ./web.
import http from "node:http";
import fs from "node:fs";
import path from "node:path";
import { fileURLToPath } from "node:url";
const ROOT = path.dirname(fileURLToPath(import.meta.url));
const port = Number(process.argv[2] ?? 8080);
const data = path.resolve(process.argv[3] ?? path.join(ROOT, "data"));
const routes = [
  ["/assets/", path.join(ROOT, "node_modules/@foxglove/studio-base/assets")],
  ["/vendor/react/", path.join(ROOT, "node_modules/react/umd")],
  ["/vendor/react-dom/", path.join(ROOT, "node_modules/react-dom/umd")],
  ["/data/", data],
  ["/layouts/", path.join(ROOT, "layouts")],
  ["/", path.join(ROOT, "web")],
];
const mime = { ".html": "text/html", ".js": "text/javascript", ".wasm": "application/wasm", ".json": "application/json",
  ".png": "image/png", ".ttf": "font/ttf", ".mcap": "application/octet-stream", ".css": "text/css" };
http.createServer((req, res) => {
  const url = new URL(req.url, "http://x");
  let p = decodeURIComponent(url.pathname);
  if (p === "/") p = "/index.html";
  const [prefix, dir] = routes.find(([pre]) => p.startsWith(pre));
  const file = path.join(dir, p.slice(prefix.length));
  res.setHeader("Access-Control-Allow-Origin", "*");
  res.setHeader("Access-Control-Allow-Headers", "*");
  res.setHeader("Access-Control-Expose-Headers", "Content-Length, Content-Range, Accept-Ranges, ETag");
  if (req.method === "OPTIONS") { res.writeHead(204); return res.end(); }
  if (!file.startsWith(dir) || !fs.existsSync(file) || !fs.statSync(file).isFile()) { res.writeHead(404); return res.end("not found"); }
  const st = fs.statSync(file);
  const headers = { "Content-Type": mime[path.extname(file)] ?? "application/octet-stream", "Accept-Ranges": "bytes",
    "ETag": `"${st.size}-${st.mtimeMs}"`, "Last-Modified": st.mtime.toUTCString(), "Cache-Control": "no-cache" };
  const m = /^bytes=(\d*)-(\d*)$/.exec(req.headers.range ?? "");
  if (m) {
    let start = m[1] === "" ? st.size - Number(m[2]) : Number(m[1]);
    let end = m[1] !== "" && m[2] !== "" ? Math.min(Number(m[2]), st.size - 1) : st.size - 1;
    if (start > end || start >= st.size) { res.writeHead(416, { "Content-Range": `bytes */${st.size}` }); return res.end(); }
    res.writeHead(206, { ...headers, "Content-Range": `bytes ${start}-${end}/${st.size}`, "Content-Length": end - start + 1 });
    if (req.method === "HEAD") return res.end();
    return fs.createReadStream(file, { start, end }).pipe(res);
  }
  res.writeHead(200, { ...headers, "Content-Length": st.size });
  if (req.method === "HEAD") return res.end();
  fs.createReadStream(file).pipe(res);
}).listen(port, "127.0.0.1", () => console.log(`serving on http://127.0.0.1:${port}/`));
