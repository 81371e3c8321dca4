// Screenshot of Lichtblick (web build) connected to `rig view`, with a pre-seeded layout.
// Usage: node screenshot_lichtblick.mjs OUT.png [APP_URL] [WS_URL]
// Needs puppeteer-core (resolved from NODE_PATH or cwd) and CHROMIUM (default /usr/bin/chromium).
import { createRequire } from "node:module";
import { mkdtempSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";

const require = createRequire(join(process.cwd(), "x.js"));
const puppeteer = require("puppeteer-core");

const [out = "lichtblick.png", app = "http://127.0.0.1:8080/", ws = "ws://127.0.0.1:8765"] =
  process.argv.slice(2);
const settleMs = Number(process.env.SETTLE_MS ?? 15000);

const fused = "/sensors/lidar/fused/points";
const front = "/sensors/lidar/front/points";
const image = "/sensors/camera/front_narrow/image_raw";
// 3D panel config (RendererConfig, panels/ThreeDeeRender/IRenderer.ts). The rig publishes no /tf,
// so each 3D panel shows the clouds of its own display frame (followTf) only.
const cloud = { visible: true, colorField: "intensity", colorMode: "colormap", colorMap: "turbo", pointSize: 2 };
const threeDee = (title, frame, topic, distance) => ({
  foxglovePanelTitle: title,
  followTf: frame,
  followMode: "follow-pose",
  cameraState: { distance, perspective: true, phi: 55, thetaOffset: 200, target: [0, 0, 0],
    targetOffset: [0, 0, 0], targetOrientation: [0, 0, 0, 1], fovy: 45, near: 0.5, far: 5000 },
  scene: { backgroundColor: "#101418" },
  topics: { [topic]: cloud },
  layers: { grid: { layerId: "foxglove.Grid", instanceId: "grid", visible: true, size: 40, divisions: 20,
    lineWidth: 1, color: "#3a4a5a", position: [0, 0, 0], rotation: [0, 0, 0], frameLocked: true } },
  transforms: {},
  publish: {},
  imageMode: {},
});
// LayoutData (context/CurrentLayoutContext/actions.ts): panel configs by id and their arrangement.
const layout = {
  configById: {
    "3D!fused": threeDee(`3D: ${fused} (fused, base_link)`, "base_link", fused, 45),
    "3D!front": threeDee(`3D: ${front} (lidar_front)`, "lidar_front", front, 30),
    "Image!cam": { foxglovePanelTitle: `Image: ${image}`, imageMode: { imageTopic: image },
      topics: {}, layers: {}, transforms: {} },
    // /rig/stamps carries every sensor's stamps; a message path filter keeps the front LIDAR's.
    "RawMessages!stamps": { topicPath: `/rig/stamps{topic=="${front}"}`, diffEnabled: false, diffMethod: "custom",
      diffTopicPath: "", showFullMessageForDiff: false, expansion: "all" },
  },
  globalVariables: {},
  userNodes: {},
  playbackConfig: { speed: 1 },
  layout: {
    direction: "row",
    splitPercentage: 58,
    first: { direction: "column", splitPercentage: 62, first: "3D!fused", second: "3D!front" },
    second: { direction: "column", splitPercentage: 45, first: "Image!cam", second: "RawMessages!stamps" },
  },
};

const profile = mkdtempSync(join(tmpdir(), "lichtblick-chromium-")); // fresh profile: no saved layouts
const browser = await puppeteer.launch({
  executablePath: process.env.CHROMIUM ?? "/usr/bin/chromium",
  headless: true,
  userDataDir: profile,
  // No GPU here: WebGL (3D and Image panels) through SwiftShader, Chromium's software renderer.
  args: ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--window-size=1600,1000"],
  defaultViewport: { width: 1600, height: 1000 },
});
try {
  const page = await browser.newPage();
  page.on("pageerror", (e) => console.error("pageerror:", process.env.DEBUG ? e.stack : e.message));
  if (process.env.DEBUG) {
    page.on("console", (m) => console.error("console:", m.type(), m.text().slice(0, 300)));
    page.on("requestfailed", (r) => console.error("requestfailed:", r.url(), r.failure()?.errorText));
  }
  // A fresh profile has no layouts, so Lichtblick saves and selects "Default", built from
  // globalThis.LICHTBLICK_SUITE_DEFAULT_LAYOUT (providers/CurrentLayoutProvider/defaultLayout.ts),
  // the hook for self-hosted defaults. index.html assigns its placeholder (undefined) to it; the
  // no-op setter keeps ours.
  await page.evaluateOnNewDocument((l) => {
    Object.defineProperty(globalThis, "LICHTBLICK_SUITE_DEFAULT_LAYOUT", { get: () => l, set: () => {} });
  }, layout);
  const url = `${app}?ds=foxglove-websocket&ds.url=${encodeURIComponent(ws)}`;
  // "load", not "networkidle2": once connected the app keeps fetching; networkidle2 timed out once.
  await page.goto(url, { waitUntil: "load", timeout: 60000 });
  await new Promise((r) => setTimeout(r, 3000)); // app up
  await page.keyboard.press("Escape"); // close a first-run dialog, if any
  await page.mouse.click(800, 500); // focus the workspace (on a 3D panel; a click there only selects)
  await page.keyboard.press("["); // Workspace.tsx shortcut: toggle the left sidebar, for room
  await new Promise((r) => setTimeout(r, settleMs)); // panels resize, subscribe, receive frames
  await page.screenshot({ path: out });
  console.log("wrote", out);
} finally {
  await browser.close();
  rmSync(profile, { recursive: true, force: true });
}
