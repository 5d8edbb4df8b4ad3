"""Watching an episode in Meshcat: the server, waiting for a browser, captions, replays.

* `make_meshcat(live, host)`: a Meshcat server, listening on loopback (`localhost`) unless
  another host is asked for (then with a warning: Meshcat has no authentication and
  accepts a websocket from any origin). Drake's "Meshcat listening for connections at
  http://..." line is not logged (it writes an IPv6 address without brackets); a live
  view prints `meshcat_url` instead. `check_meshcat_host` refuses, before any work, a
  host that is not this machine's (Drake's own failure names neither host nor flag).
* `wait_for_browser(meshcat, timeout)`: block until a browser (any websocket client) is
  connected.
* `serve_until_interrupted(meshcat)`: keep the server (and so the scene) alive until
  Ctrl-C, for the user to look at the end of a live episode.
* `ReplayCaption`: what the run was (planner, plant, seed) and how it ended; it is
  written into the HTML replay as an overlay (`replay_html`, `write_replay_html`) with
  the colour legend, and shown live as labels in Meshcat's control panel
  (`show_caption_controls`): Meshcat has no text primitive.
"""

from __future__ import annotations

import dataclasses as dc
import html
import ipaddress
import logging
import socket
import time
from pathlib import Path

from pydrake.geometry import Meshcat, MeshcatParams

from emonav_drake import palette
from emonav_drake.params import ConfigError
from emonav_drake.systems import navigation_meshcat as nm
from emonav_drake.systems import navigation_meshcat_style as style

log = logging.getLogger(__name__)


def _css(rgba) -> str:
    """A Drake `Rgba` as a CSS colour (opaque)."""
    return palette.css((rgba.r(), rgba.g(), rgba.b()))


# (label, CSS colour) of the legend: the colours `NavigationMeshcatVisualizer` draws with
LEGEND = (
    ("happy pedestrian", _css(style.EMOTION_RGBA[0])),
    ("neutral pedestrian", _css(style.EMOTION_RGBA[1])),
    ("negative pedestrian", _css(style.EMOTION_RGBA[2])),
    ("static disc or wall", _css(style.STATIC_RGBA)),
    ("robot and its trail", _css(style.ROBOT_RGBA)),
    ("start (square pad)", palette.css(palette.ROBOT_RGB, style.START_RGBA.a())),
    ("goal", _css(style.GOAL_RGBA)),
)
RAYS_LEGEND = (
    ("LiDAR rays (per walking step)", _css(style.RAY_RGBA)),
    ("LiDAR returns (per walking step, drawn above the heads)", _css(style.HIT_RGBA)),
)
TRACKS_LEGEND = (
    ("tracked pedestrian (LiDAR), arrow: 1 s of its velocity", palette.css(palette.TRACK_RGB)),
    ("tracked static obstacle (LiDAR)", palette.css(palette.TRACK_STATIC_RGB)),
)
ROUTE_LEGEND = (("global route, its sub-goal (sphere)", _css(style.GOAL_RGBA)),)
FOOTSTEP_LEGEND = (
    ("footstep target, left", _css(style.FOOT_RGBA[0])),
    ("footstep target, right", _css(style.FOOT_RGBA[1])),
)
# the legend in words, for Meshcat's control panel (no colours there; ~44 characters fit)
LIVE_LEGEND = (
    "happy green, neutral orange, negative red",
    "discs, walls grey, robot blue, goal black",
)


LOOPBACK_HOST = "localhost"  # Meshcat's default host here: this machine only


def is_loopback_host(host: str) -> bool:
    """True for a host name or address that only this machine can reach."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.strip("[]")).is_loopback
    except ValueError:
        return False


def _bare(host: str) -> str:
    """An IPv6 address without the brackets of a URL: "[::1]" → "::1"."""
    return host[1:-1] if host.startswith("[") and host.endswith("]") else host


def check_meshcat_host(host: str, flag: str = "--meshcat-host") -> str:
    """`host` as Meshcat is given it (brackets of an IPv6 address removed), if Meshcat can
    listen there: "*" (every interface), or a name or address that resolves to an
    address of this machine (a socket can be bound to it). `ConfigError` naming `flag`
    otherwise (an unknown name, another machine's address)."""
    if host == "*":
        return host
    bare = _bare(host)
    choices = "give localhost (this machine only), '*' (every interface) or an address of "
    choices += "this machine"
    try:
        infos = socket.getaddrinfo(bare, 0, type=socket.SOCK_STREAM)
    except (socket.gaierror, UnicodeError) as e:
        why = getattr(e, "strerror", None) or str(e)
        raise ConfigError(
            f"{flag} {host!r}: not a host name or address this machine can resolve ({why}); "
            f"{choices}"
        ) from None
    problem: OSError | None = None
    for family, kind, proto, _, address in infos:
        with socket.socket(family, kind, proto) as sock:
            try:
                sock.bind(address)  # port 0: any free one; fails for another machine's address
                return bare
            except OSError as e:
                problem = problem or e
    why = problem.strerror if problem is not None and problem.strerror else "cannot bind"
    raise ConfigError(
        f"{flag} {host!r}: not an address of this machine ({why}), so Meshcat cannot listen "
        f"there; {choices}"
    )


def meshcat_url(meshcat: Meshcat) -> str:
    """The address to open in a browser: Drake's `web_url()`, with an IPv6 host in
    brackets (`http://[::1]:7000`, not `http://::1:7000`)."""
    url = meshcat.web_url()
    scheme, sep, rest = url.partition("://")
    host, colon, port = rest.rpartition(":")
    if sep and colon and ":" in host and not host.startswith("["):
        return f"{scheme}://[{host}]:{port}"
    return url


def make_meshcat(live: bool, host: str = LOOPBACK_HOST, port: int | None = None) -> Meshcat:
    """A Meshcat server listening on `host` (default loopback only).

    Args:
        live: True for a server someone watches (`start_live_view` prints its URL), False
            for recording only. Either way Drake's own log line announcing the URL is
            suppressed (it writes an IPv6 host without brackets).
        host: the interface to listen on: "localhost" (default), an address of this
            machine (an IPv6 one with or without brackets), or "*" for every interface.
            Anything but loopback logs a warning: Meshcat has no authentication and
            accepts a websocket from any origin, so whoever reaches that interface can
            watch and change the scene.
        port: the port (None: Drake's choice, the first free one from 7000).
    Raises:
        ConfigError: Meshcat could not listen there (not this machine's address, or no
            free port), naming the host.
    """
    host = _bare(host)
    if not is_loopback_host(host):
        log.warning(
            "Meshcat listens on %s: any host that reaches this machine there can watch and "
            "change the scene (no authentication); use it on a trusted network only",
            "every interface" if host in ("*", "0.0.0.0", "::") else host,
        )
    params = MeshcatParams(host=host, port=port)
    drake_log = logging.getLogger("drake")
    level = drake_log.level
    drake_log.setLevel(logging.WARNING)
    try:
        meshcat = Meshcat(params)
        set_legend_lighting(meshcat)
        return meshcat
    except RuntimeError as e:  # "Meshcat failed to open a websocket port."
        where = f"port {port}" if port is not None else "a port from 7000"
        what = "Meshcat" if host == LOOPBACK_HOST else f"--meshcat-host {host!r}: Meshcat"
        raise ConfigError(
            f"{what} could not listen on {where} of {host} ({e}); give localhost, '*' or an "
            "address of this machine, and check that a port is free"
        ) from None
    finally:
        drake_log.setLevel(level)


# Mostly ambient light: under Meshcat's default lights (bright point and spot lights, dim
# ambient) an orange (neutral) pedestrian looked yellow and a vermillion (negative) one
# orange, against the legend. With these, surfaces show nearly their own colours and keep
# a little shading (checked in headless Chromium screenshots of replays).
AMBIENT_INTENSITY = 2.4
DIRECTIONAL_INTENSITY = 0.5
_LIGHTS = ("FillLight", "PointLightNegativeX", "PointLightPositiveX", "SpotLight")


def set_legend_lighting(meshcat: Meshcat) -> None:
    """Light the scene so that the drawn colours match the legend's (see the constants)."""
    meshcat.SetProperty("/Lights/AmbientLight/<object>", "intensity", AMBIENT_INTENSITY)
    for name in _LIGHTS:
        meshcat.SetProperty(f"/Lights/{name}/<object>", "intensity", DIRECTIONAL_INTENSITY)


def wait_for_browser(meshcat: Meshcat, timeout: float | None = None, poll: float = 0.05) -> bool:
    """Block until at least one client is connected to `meshcat`'s websocket.

    Args:
        timeout: give up after this many seconds (None: wait forever; Ctrl-C stops it).
        poll: polling period [s].
    Returns True when a client is connected, False on timeout."""
    deadline = None if timeout is None else time.monotonic() + timeout
    while meshcat.GetNumActiveConnections() == 0:
        if deadline is not None and time.monotonic() >= deadline:
            return False
        time.sleep(poll)
    return True


def serve_until_interrupted(meshcat: Meshcat, poll: float = 0.5) -> None:
    """Keep `meshcat` (the caller's reference keeps the server alive) serving its scene
    until Ctrl-C; returns then, quietly."""
    try:
        while True:
            time.sleep(poll)
    except KeyboardInterrupt:
        pass


@dc.dataclass
class ReplayCaption:
    """What a replay shows: planner, plant and seed; outcome once the episode has ended.

    Attributes:
        planner: planner name ("dwa", "mpc", "policy", ...).
        plant: "LIP" or "Digit".
        seed: the scenario's seed (None for a hand-made scenario without one).
        outcome: "success", "collision", "timeout", "fall", "no_route" (None while
            running).
        steps: walking steps taken; nav_time: simulated time [s].
        rays: the replay draws LiDAR rays; footsteps: it draws footstep targets; tracks:
            it draws the LiDAR tracks the state-based planners read (`--state-source lidar`);
            route: it draws the global route and its sub-goal; scene: the scene in words
            (a scenario file's name, a family and seed) instead of "seed N".
    """

    planner: str
    plant: str
    seed: int | None = None
    outcome: str | None = None
    steps: int | None = None
    nav_time: float | None = None
    rays: bool = False
    footsteps: bool = False
    tracks: bool = False
    route: bool = False
    scene: str | None = None  # what ran, e.g. "scenario closed_door", "family office, seed 3"

    @classmethod
    def for_episode(
        cls,
        planner,
        plant: str,
        scenario,
        record=None,
        rays: bool = False,
        footsteps: bool = False,
        tracks: bool = False,
        route: bool = False,
        scene: str | None = None,
    ) -> ReplayCaption:
        """The caption of an episode: `planner` a `Planner` (its `name`), `plant` the
        robot's caption name (`Plant.caption_name`), `scenario` a `Scenario` (its `seed`),
        `record` its `EpisodeRecord` once it has ended; `footsteps` as the plant's."""
        from emonav_drake.planners import is_default_checkpoint

        name = getattr(planner, "name", type(planner).__name__)
        path = getattr(planner, "path", None)  # a learned policy: its checkpoint file
        shown = name  # the planner's name; its file only when the user chose one
        if path is not None and not is_default_checkpoint(name, path):
            shown = f"{name} ({Path(path).name})"
        cap = cls(
            planner=shown,
            plant=plant,
            seed=getattr(scenario, "seed", None),
            rays=rays,
            footsteps=footsteps,
            tracks=tracks,
            route=route,
            scene=scene,
        )
        if record is not None:
            cap.set_outcome(record)
        return cap

    def set_outcome(self, record) -> None:
        """Take outcome, steps and simulated time from an `EpisodeRecord`."""
        self.outcome, self.steps, self.nav_time = record.outcome, record.steps, record.nav_time

    def title(self) -> str:
        if self.scene:
            return f"emonav: {self.planner} on {self.plant}, {self.scene}"
        seed = "" if self.seed is None else f", seed {self.seed}"
        return f"emonav: {self.planner} on {self.plant}{seed}"

    def outcome_line(self) -> str:
        if self.outcome is None:
            return "outcome: running"
        return f"outcome: {self.outcome} after {self.steps} steps ({self.nav_time:.1f} s)"

    def legend(self) -> list[tuple[str, str]]:
        items = list(LEGEND)
        if self.rays:
            items.extend(RAYS_LEGEND)
        if self.footsteps:
            items.extend(FOOTSTEP_LEGEND)
        if self.tracks:
            items.extend(TRACKS_LEGEND)
        if self.route:
            items.extend(ROUTE_LEGEND)
        return items


def caption_overlay(caption: ReplayCaption) -> str:
    """The caption and colour legend as an HTML `<div>` (fixed, top left)."""
    rows = "".join(
        f'<div><span style="display:inline-block;width:0.9em;height:0.9em;'
        f'border-radius:50%;background:{colour};margin-right:0.4em;vertical-align:-0.1em">'
        f"</span>{html.escape(label)}</div>"
        for label, colour in caption.legend()
    )
    return (
        '<div id="emonav-caption" style="position:fixed;top:8px;left:8px;z-index:10;'
        f"background:{palette.css(palette.CAPTION_BOX_RGB, 0.85)};padding:8px 12px;"
        "border-radius:6px;font:13px/1.45 sans-serif;"
        f'color:{palette.css(palette.CAPTION_TEXT_RGB)};pointer-events:none">'
        f'<div style="font-weight:bold">{html.escape(caption.title())}</div>'
        f"<div>{html.escape(caption.outcome_line())}</div>"
        f'<div style="margin-top:4px">{rows}</div>'
        "</div>"
    )


def playback_bar() -> str:
    """The replay's clock and controls at hand (fixed, bottom left): play / pause, a time
    slider, and the simulated time "t = 12.4 s / 35.6 s" of the animation. Meshcat's
    animator (the page's global `viewer.animator`) plays the recording; its clip time is
    the simulated time."""
    box = palette.css(palette.CAPTION_BOX_RGB, 0.85)
    text = palette.css(palette.CAPTION_TEXT_RGB)
    return (
        '<div id="emonav-playback" style="position:fixed;bottom:10px;left:8px;z-index:10;'
        f"background:{box};padding:6px 10px;border-radius:6px;font:13px/1.4 sans-serif;"
        f'color:{text};display:flex;gap:8px;align-items:center">'
        '<button id="emonav-play" style="font:inherit;min-width:4.5em">play</button>'
        '<input id="emonav-time" type="range" min="0" max="1000" value="0" '
        'style="width:min(46vw,520px)">'
        '<span id="emonav-clock" style="font-variant-numeric:tabular-nums">t = 0.0 s</span>'
        "</div>\n" + _PLAYBACK_SCRIPT
    )


_PLAYBACK_SCRIPT = """<script>
(function () {
  const btn = document.getElementById("emonav-play");
  const slider = document.getElementById("emonav-time");
  const clock = document.getElementById("emonav-clock");
  let dragging = false;
  function anim() { return window.viewer && window.viewer.animator; }
  function now(a) { return a.actions.length ? a.actions[0].time : 0; }
  setInterval(function () {
    const a = anim();
    if (!a || !a.duration) return;
    const t = Math.min(now(a), a.duration);
    clock.textContent = "t = " + t.toFixed(1) + " s / " + a.duration.toFixed(1) + " s";
    if (!dragging) slider.value = Math.round(1000 * t / a.duration);
    btn.textContent = a.playing ? "pause" : "play";
  }, 100);
  btn.onclick = function () {
    const a = anim();
    if (!a) return;
    if (a.playing) { a.pause(); } else { a.play(); }
  };
  slider.onpointerdown = function () { dragging = true; };
  slider.onpointerup = function () { dragging = false; };
  slider.oninput = function () {
    const a = anim();
    if (!a || !a.duration) return;
    a.pause();
    a.seek(slider.value / 1000 * a.duration);
  };
})();
</script>"""


# Three.js keeps the vertical field of view when the window's shape changes, so a narrow
# (portrait) window would cut the arena's sides: widen the vertical view (never narrow
# it) until the horizontal one is at least the overview's. Meshcat's viewer is the
# page's global `viewer`; its camera may be replaced when the scene loads, hence a poll.
_FIT_VIEW_SCRIPT = """<script>
(function () {
  function fit() {
    const cam = window.viewer && window.viewer.camera;
    if (!cam || !cam.isPerspectiveCamera) return;
    if (cam.userData.emonavFov === undefined) cam.userData.emonavFov = cam.fov;
    const half = Math.tan(MIN_HFOV * Math.PI / 360) / cam.aspect;
    const fov = Math.max(cam.userData.emonavFov, 360 / Math.PI * Math.atan(half));
    if (Math.abs(cam.fov - fov) > 1e-6) { cam.fov = fov; window.viewer.set_dirty(); }
  }
  setInterval(fit, 250);
})();
</script>"""


def replay_html(meshcat: Meshcat, caption: ReplayCaption) -> str:
    """`meshcat.StaticHtml()` with the caption overlay, the playback bar (clock, play /
    pause, time slider) and the script that keeps the arena in view in narrow windows,
    inserted before `</body>`."""
    page = meshcat.StaticHtml()
    at = page.rfind("</body>")
    if at < 0:  # not the page layout we know: leave the replay as Drake wrote it
        log.warning("Meshcat's StaticHtml has no </body>: replay written without caption")
        return page
    script = _FIT_VIEW_SCRIPT.replace("MIN_HFOV", f"{nm.OVERVIEW_MIN_HFOV:g}")
    extra = caption_overlay(caption) + "\n" + playback_bar() + "\n" + script + "\n"
    return page[:at] + extra + page[at:]


def write_replay_html(meshcat: Meshcat, path: str | Path, caption: ReplayCaption) -> None:
    """Write the self-contained HTML replay of `meshcat`'s published recording."""
    Path(path).write_text(replay_html(meshcat, caption))
    log.info("wrote Meshcat replay %s", path)


def show_caption_controls(meshcat: Meshcat, caption: ReplayCaption) -> None:
    """Show the caption live, as labels (inert buttons) in Meshcat's control panel; call
    again with the outcome to update it."""
    for name in meshcat.GetButtonNames():
        if name.startswith(("emonav:", "outcome:")) or name in LIVE_LEGEND:
            meshcat.DeleteButton(name, strict=False)
    for label in (caption.title(), caption.outcome_line(), *LIVE_LEGEND):
        meshcat.AddButton(label)


def start_live_view(meshcat: Meshcat, wait: bool, caption: ReplayCaption | None = None) -> None:
    """Print the URL, show the caption (if any) in the control panel and, with `wait`,
    block until a browser is connected (Ctrl-C stops the wait)."""
    print(f"Meshcat: {meshcat_url(meshcat)}", flush=True)
    if caption is not None:
        show_caption_controls(meshcat, caption)
    if wait and meshcat.GetNumActiveConnections() == 0:
        print(
            f"waiting for a browser at {meshcat_url(meshcat)} (open it; --no-wait to start "
            "at once, Ctrl-C to quit)",
            flush=True,
        )
        wait_for_browser(meshcat)
        print("browser connected: starting", flush=True)


def finish_live_view(
    meshcat: Meshcat, keep_serving: bool, caption: ReplayCaption | None = None
) -> None:
    """Show the caption (with its outcome) in the control panel and, with
    `keep_serving`, keep the scene served until Ctrl-C."""
    if caption is not None:
        show_caption_controls(meshcat, caption)
    if keep_serving:
        print(f"Meshcat still serving at {meshcat_url(meshcat)} (Ctrl-C to exit)", flush=True)
        serve_until_interrupted(meshcat)
