// Host shell replacing packages/studio-web (Root.tsx/index.tsx) of foxglove/studio v1.48,
// using the globals exported by the studio-base UMD bundle (App, McapLocalDataSourceFactory, ...).
(async function main() {
  const g = window;
  const params = new URLSearchParams(location.search);

  // ---- App configuration (settings) in localStorage, like studio-web's LocalStorageAppConfiguration
  const CFG_KEY = "viewer.appConfig";
  const cfg = Object.assign({}, JSON.parse(localStorage.getItem(CFG_KEY) ?? "{}"));
  const listeners = new Map();
  const appConfiguration = {
    get: (k) => cfg[k],
    set: async (k, v) => { cfg[k] = v; localStorage.setItem(CFG_KEY, JSON.stringify(cfg)); (listeners.get(k) ?? []).forEach((cb) => cb(v)); },
    addChangeListener: (k, cb) => listeners.set(k, [...(listeners.get(k) ?? []), cb]),
    removeChangeListener: (k, cb) => listeners.set(k, (listeners.get(k) ?? []).filter((x) => x !== cb)),
  };

  // ---- Layout storage (ILayoutStorage) in localStorage key "viewer.layouts" = {namespace: {id: Layout}}
  const LS_KEY = "viewer.layouts";
  const load = () => JSON.parse(localStorage.getItem(LS_KEY) ?? "{}");
  const save = (all) => localStorage.setItem(LS_KEY, JSON.stringify(all));
  const layoutStorage = {
    list: async (ns) => Object.values(load()[ns] ?? {}),
    get: async (ns, id) => (load()[ns] ?? {})[id],
    put: async (ns, layout) => { const all = load(); (all[ns] ??= {})[layout.id] = layout; save(all); return layout; },
    delete: async (ns, id) => { const all = load(); delete (all[ns] ?? {})[id]; save(all); },
    importLayouts: async () => {},
  };

  // ---- Optional layout preset: ?layoutUrl=/layouts/x.json[&layoutId=name]  (file content = LayoutData:
  //      {configById, globalVariables, userNodes, playbackConfig, layout})
  const layoutUrl = params.get("layoutUrl");
  if (layoutUrl) {
    const data = await (await fetch(layoutUrl)).json();
    const id = params.get("layoutId") ?? "preset";
    const now = new Date().toISOString();
    await layoutStorage.put("local", { id, name: id, permission: "CREATOR_WRITE",
      baseline: { data, savedAt: now }, working: undefined, syncInfo: undefined });
    if (!params.get("layoutId")) { params.set("layoutId", id); history.replaceState(null, "", "?" + params.toString()); }
  }

  // ---- Optional UI presets for headless screenshots
  //  ?sidebar=none  -> start with the left "Data source / Topics" sidebar closed (zustand store "fox.workspace")
  if (params.get("sidebar") === "none") {
    localStorage.setItem("fox.workspace", JSON.stringify({ state: { sidebarItem: null }, version: 0 }));
  }
  //  mark the per-panel "Open settings to configure..." onboarding tooltips as already shown (profile in "studio.profile-data")
  const prof = JSON.parse(localStorage.getItem("studio.profile-data") ?? "{}");
  prof.onboarding = { settingsTooltipShownForPanelTypes: ["3D", "ImageViewPanel", "RawMessages", "map", "Plot"] };
  localStorage.setItem("studio.profile-data", JSON.stringify(prof));

  g.overwriteFetch();
  await g.waitForFonts();
  await g.initI18n();

  const dataSources = [
    new g.McapLocalDataSourceFactory(),
    new g.RemoteDataSourceFactory(),
    new g.Ros1LocalBagDataSourceFactory(),
    new g.Ros2LocalBagDataSourceFactory(),
    new g.FoxgloveWebSocketDataSourceFactory(),
    new g.RosbridgeDataSourceFactory(),
    new g.UlogLocalDataSourceFactory(),
  ];
  const e = React.createElement;
  ReactDOM.render(
    e(g.App, {
      deepLinks: [location.href],
      dataSources,
      appConfiguration,
      layoutStorage,
      extensionLoaders: [],
      enableGlobalCss: true,
    }),
    document.getElementById("root"),
  );
  console.debug("App rendered");
})().catch((err) => { console.error("host.js failed", err); document.body.insertAdjacentText("afterbegin", "host.js failed: " + err); });
