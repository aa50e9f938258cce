// LaserArena replay viewer: reads a replay (docs/replay.md) in the browser and draws it on a
// canvas as arena/draw.py draws a frame with pygame (same colours, geometry and rounding), so
// the page and `laserarena render` show the same picture. `window.viewer` is its handle.
"use strict";
(() => {
  const DATA = JSON.parse(document.getElementById("laserarena-data").textContent);
  const S = DATA.style;  // arena/draw.py's colours and sizes, referee/media/render.py's windows
  const $ = (id) => document.getElementById(id);

  // ---- Python's arithmetic, so pixels round as they do in arena/draw.py ----
  function pyRound(v) {  // round half to even, as Python's round()
    const f = Math.floor(v), d = v - f;
    return d > 0.5 ? f + 1 : d < 0.5 ? f : (f % 2 === 0 ? f : f + 1);
  }
  const rgb = (c) => `rgb(${c[0]},${c[1]},${c[2]})`;
  const mix = (a, b, t) => a.map((x, i) => pyRound(x + (b[i] - x) * t));
  const colour = (slot) => S.palette[((slot % S.palette.length) + S.palette.length) % S.palette.length];
  function bisectRight(arr, x) {
    let lo = 0, hi = arr.length;
    while (lo < hi) { const mid = (lo + hi) >> 1; if (x < arr[mid]) hi = mid; else lo = mid + 1; }
    return lo;
  }
  function bisectLeft(arr, x) {
    let lo = 0, hi = arr.length;
    while (lo < hi) { const mid = (lo + hi) >> 1; if (arr[mid] < x) lo = mid + 1; else hi = mid; }
    return lo;
  }
  function latest(series, t) {
    if (!series) return null;
    const i = bisectRight(series.times, t) - 1;
    return i >= 0 ? series.values[i] : null;
  }

  const TAU = 2 * Math.PI;
  function remainder(x, y) {  // IEEE remainder, as Python's math.remainder
    const q = x / y;
    let n = Math.round(q);
    if (Math.abs(q % 1) === 0.5) n = 2 * Math.round(q / 2);
    return x - n * y;
  }

  // ---- reading a replay: gzip'd JSON lines ----
  async function gunzip(bytes) {
    const stream = new Blob([bytes]).stream().pipeThrough(new DecompressionStream("gzip"));
    return await new Response(stream).text();
  }

  function parseReplay(text, name) {
    const lines = text.split("\n");
    let header = null;
    try { header = JSON.parse(lines[0]); } catch (e) { /* reported below */ }
    if (!header || header.format !== "laserarena-replay") throw new Error(`${name}: not a LaserArena replay`);
    if (header.version !== 1) throw new Error(`${name}: replay format version ${header.version}, this page reads 1`);
    const rep = { header, frames: [], events: [], estimates: [], debug: [], fouls: [], faults: [], trials: [], result: null };
    const lists = { e: rep.events, est: rep.estimates, dbg: rep.debug, foul: rep.fouls, fault: rep.faults, trial: rep.trials };
    for (let n = 1; n < lines.length; n++) {
      if (!lines[n]) continue;
      let rec;
      try { rec = JSON.parse(lines[n]); } catch (e) { throw new Error(`${name}: a truncated or damaged replay (line ${n + 1})`); }
      if (rec.k === "f") rep.frames.push([rec.t, rec.p]);
      else if (rec.k === "result") rep.result = rec.result;
      else if (rec.k in lists) lists[rec.k].push(rec);
    }
    if (!rep.frames.length) throw new Error(`${name}: a replay without frames`);
    return rep;
  }

  const frameAt = (rep, t) => Math.min(Math.max(pyRound(t * rep.header.record_rate), 0), rep.frames.length - 1);

  // ---- estimate errors and standings (referee/media/error_series.py, referee/media/standings.py) ----
  function truthAt(frames, times, slot, t, moves) {  // the true pose at t, between frames linearly, never across a move
    const i = bisectLeft(times, t - 1e-9);
    if (i >= frames.length) return null;
    if (Math.abs(times[i] - t) <= 1e-9 || i === 0) return frames[i][1][slot];
    const [t0, p0] = frames[i - 1], [t1, p1] = frames[i], a = p0[slot], b = p1[slot];
    for (const move of moves) {
      if (t0 - 1e-9 <= move && move <= t1 + 1e-9) return t <= move + 1e-9 ? a : b;
    }
    const w = (t - t0) / (t1 - t0), dh = remainder(b[2] - a[2], TAU);
    return [a[0] + w * (b[0] - a[0]), a[1] + w * (b[1] - a[1]), remainder(a[2] + w * dh, TAU)];
  }

  class Standings {
    constructor(rep, geom) {
      const n = geom.robots.length, kind = geom.task.kind, radius = geom.task.radius, P = S.points;
      this.rep = rep; this.geom = geom; this.P = P;
      this.targets = geom.targets;
      this.duration = rep.frames[rep.frames.length - 1][0];
      this.reached = geom.robots.map(() => []);  // per frame, from the frames (a replay without its result)
      this.finished = Array(n).fill(null);
      const next = Array(n).fill(0);
      for (const [t, poses] of rep.frames) {
        poses.forEach(([x, y], slot) => {
          const targets = this.targets[slot];
          if (t > 0 && kind !== "goto") {  // the referee tracks after physics steps; a goto arrival is a stop
            while (next[slot] < targets.length && Math.hypot(x - targets[next[slot]][0], y - targets[next[slot]][1]) <= radius) {
              next[slot] += 1;
              if (next[slot] === targets.length) this.finished[slot] = t;
            }
          }
          this.reached[slot].push(next[slot]);
        });
      }
      const frameTimes = rep.frames.map((f) => f[0]);
      this.errors = geom.robots.map((_, slot) => {
        const track = { times: [], position: [], heading: [], qualities: [] };
        const moves = rep.trials.map((r) => r.t);
        for (const rec of rep.estimates) {
          if (rec.r !== slot) continue;
          const truth = truthAt(rep.frames, frameTimes, slot, rec.t, moves);
          if (truth === null) break;
          const d = Math.hypot(rec.e[0] - truth[0], rec.e[1] - truth[1]);
          const h = Math.abs(remainder(rec.e[2] - truth[2], TAU));
          track.times.push(rec.t);
          track.position.push(d);
          track.heading.push(h);
          const q = 1 / (1 + Math.hypot(d / geom.position_scale, h / geom.heading_scale));  // referee/match/estimates.py
          track.qualities.push((track.qualities.length ? track.qualities[track.qualities.length - 1] : 0) + q);
        }
        return track;
      });
    }

    frame(t) { return frameAt(this.rep, t); }

    matchTicks(slot) {  // the control ticks Q is the mean over: the result's, else the time limit's
      const result = this.rep.result, localization = result ? result.robots[slot].localization : null;
      return localization ? localization.ticks : this.geom.control_ticks;
    }

    clock(t) {  // t, or at the last frame the match's end (it may come a step or two before it)
      const result = this.rep.result;
      return result && t >= this.duration - 1e-9 ? Math.max(t, result.end_time) : t;
    }

    taskAt(slot, t) {  // [targets reached, progress 0..1, finish time] at t (referee/media/standings.py)
      const result = this.rep.result;
      if (!result) {
        const reached = this.reached[slot][this.frame(t)], targets = this.targets[slot].length;
        return [reached, targets ? reached / targets : 0, this.finished[slot]];
      }
      t = this.clock(t);
      const robot = result.robots[slot], task = robot.task;
      if (task.kind === "goto") {
        const arrived = task.finished !== null && task.finished <= t;
        return [arrived ? 1 : 0, arrived ? robot.score.task / this.P.task : 0, task.finished];
      }
      const times = task.reached_at || [], worth = task.worth || times.map(() => 1);
      let reached = 0, progress = 0;
      while (reached < times.length && times[reached] <= t) { progress += worth[reached]; reached += 1; }
      return [reached, times.length ? progress / task.total : 0, task.finished];
    }

    score(slot, t) {  // the points earned by t (docs/rules.md; referee/media/standings.py)
      const localize = this.geom.task.kind === "localize", P = this.P;
      t = this.clock(t);
      const [, progress, finished] = this.taskAt(slot, t);
      let points = localize ? 0 : P.task * progress;
      const track = this.errors[slot], n = bisectRight(track.times, t + 1e-9);
      const quality = Math.min(1, (n ? track.qualities[n - 1] : 0) / this.matchTicks(slot));
      if (finished !== null && finished <= t && !localize) points += P.time * (1 - finished / this.geom.time_limit) * quality;
      points += (localize ? P.localize_task : P.localization) * quality;
      return points - this.rep.fouls.filter((f) => f.r === slot && f.time <= t).reduce((a, f) => a + f.penalty, 0);
    }

    errorNow(slot, t) {  // [position m, heading rad] of the latest estimate by t, or null
      const track = this.errors[slot], i = bisectRight(track.times, t + 1e-9) - 1;
      return i >= 0 ? [track.position[i], track.heading[i], track.times[i]] : null;
    }

    line(slot, team, t) {  // the HUD line of one robot
      const kind = this.geom.task.kind, [reached, progress] = this.taskAt(slot, t);
      const task = kind === "localize" ? "localize"
        : kind === "goto" ? (reached ? `arrived, ${pyRound(100 * progress).toFixed(0)} %` : "not arrived")
        : `${reached}/${this.targets[slot].length} waypoints`;
      const err = this.errorNow(slot, t);
      const shown = err ? `err ${(1000 * err[0]).toFixed(0)} mm ${(180 / Math.PI * err[1]).toFixed(0)} deg` : "no estimate";
      return `${slot} ${team}   score ${this.score(slot, t).toFixed(1).padStart(6)}   ${task}   ${shown}`;
    }
  }

  // ---- scenes: what to draw at time t (referee/media/render.py's Scenes) ----
  class Scenes {
    constructor(rep, geom) {
      this.rep = rep;
      this.geom = geom;
      this.rate = rep.header.record_rate;
      this.duration = rep.frames[rep.frames.length - 1][0];
      this.teams = (rep.header.teams || []).map((t) => t.label);
      // events with a beam, by time (a stable sort keeps equal times in written order)
      this.events = rep.events.filter((e) => e.line).sort((a, b) => a.t - b.t);
      this.eventTimes = this.events.map((e) => e.t);
      this.estimates = new Map();
      this.debug = new Map();
      for (const [source, target, key] of [[rep.estimates, this.estimates, "e"], [rep.debug, this.debug, "d"]]) {
        for (const rec of source) {
          if (!target.has(rec.r)) target.set(rec.r, { times: [], values: [] });
          const s = target.get(rec.r);
          s.times.push(rec.t);
          s.values.push(rec[key]);
        }
      }
      this.stoppedAt = new Map();
      for (const f of rep.faults) if (f.kind !== "skipped_tick") this.stoppedAt.set(f.r, f.time);
      this.foulTimes = rep.fouls.map((f) => f.time).sort((a, b) => a - b);
      this.standings = new Standings(rep, geom);
    }

    frameIndex(t) { return frameAt(this.rep, t); }

    at(t) {
      const frames = this.rep.frames, i = this.frameIndex(t);
      const first = Math.max(0, i - Math.trunc(S.trail * this.rate));
      const robots = this.geom.robots.map((model, slot) => {
        const [x, y, h] = frames[i][1][slot];
        const trail = [];
        for (let k = first; k <= i; k += 2) trail.push([frames[k][1][slot][0], frames[k][1][slot][1]]);
        return { slot, x, y, heading: h, length: model.length, width: model.width, trail,
                 estimate: latest(this.estimates.get(slot), t),
                 stopped: (this.stoppedAt.has(slot) ? this.stoppedAt.get(slot) : 1e18) <= t };
      });
      const lo = bisectRight(this.eventTimes, t - S.beam_window), hi = bisectRight(this.eventTimes, t);
      const beams = this.events.slice(lo, hi).map((e) => [e.s >= 0 ? e.s : e.r, ...e.line]);
      const drawings = [];
      for (const [slot, series] of this.debug) for (const d of latest(series, t) || []) drawings.push([slot, d]);
      const fouls = this.foulTimes.filter((f) => f <= t).length;
      const hud = [`${this.geom.name}  seed ${this.rep.header.seed}   t = ${t.toFixed(2).padStart(6)} s / `
                   + `${this.duration.toFixed(1)} s   fouls ${fouls}`, ...this.standingLines(t)];
      return { robots, beams, paths: this.geom.paths, drawings, hud, timeline: [t, this.foulTimes, this.duration] };
    }

    standingLines(t) {  // one line per robot; at the end of a finished replay, the referee's own scores
      const result = this.rep.result;
      if (result && t >= this.duration - 1e-9)
        return result.robots.map((r) => `${r.slot} ${r.team}   final score ${r.score.total.toFixed(1)}`);
      return this.teams.map((team, slot) => this.standings.line(slot, team, t));
    }
  }

  // ---- pygame.draw's primitives on a canvas: pygame's pixel (x, y) is the canvas square [x, x+1) x [y, y+1) ----
  const draw = {
    rect(ctx, c, x, y, w, h, width = 0) {
      if (width) { ctx.strokeStyle = rgb(c); ctx.lineWidth = width; ctx.strokeRect(x + width / 2, y + width / 2, w - width, h - width); }
      else { ctx.fillStyle = rgb(c); ctx.fillRect(x, y, w, h); }
    },
    polygon(ctx, c, pts, width = 0) {  // filled polygons include their border pixels
      ctx.beginPath();
      pts.forEach(([x, y], k) => (k ? ctx.lineTo : ctx.moveTo).call(ctx, Math.trunc(x) + 0.5, Math.trunc(y) + 0.5));
      ctx.closePath();
      ctx.strokeStyle = rgb(c);
      ctx.lineJoin = "miter";
      if (width) { ctx.lineWidth = width; ctx.stroke(); return; }
      ctx.fillStyle = rgb(c); ctx.fill(); ctx.lineWidth = 1; ctx.stroke();
    },
    line(ctx, c, a, b, width) { this.lines(ctx, c, [a, b], width); },
    lines(ctx, c, pts, width) {  // a thick pygame line spans whole pixels, end points included
      const off = width / 2 - Math.floor((width - 1) / 2);
      ctx.beginPath();
      for (let k = 0; k + 1 < pts.length; k++) {
        const [x0, y0] = pts[k].map(Math.trunc), [x1, y1] = pts[k + 1].map(Math.trunc);
        const dx = x1 - x0, dy = y1 - y0, len = Math.hypot(dx, dy) || 1, ux = dx / len * 0.5, uy = dy / len * 0.5;
        const [ox, oy] = Math.abs(dx) >= Math.abs(dy) ? [0.5, off] : [off, 0.5];
        ctx.moveTo(x0 + ox - ux, y0 + oy - uy);
        ctx.lineTo(x1 + ox + ux, y1 + oy + uy);
      }
      ctx.strokeStyle = rgb(c); ctx.lineWidth = width; ctx.lineCap = "butt"; ctx.stroke();
    },
    circle(ctx, c, [x, y], r, width = 0) {  // pygame centres a circle on a pixel corner
      ctx.beginPath();
      if (width) { ctx.arc(Math.trunc(x), Math.trunc(y), Math.max(r - width / 2, 0.5), 0, 2 * Math.PI); ctx.strokeStyle = rgb(c); ctx.lineWidth = width; ctx.stroke(); }
      else { ctx.arc(Math.trunc(x), Math.trunc(y), r, 0, 2 * Math.PI); ctx.fillStyle = rgb(c); ctx.fill(); }
    },
  };

  // ---- the painter: arena/draw.py's Painter ----
  class Painter {
    constructor(geom, size) {
      this.geom = geom;
      this.size = size;
      const [w, h] = size, f = geom.field;
      this.font = DATA.fonts.big;
      this.small = DATA.fonts.small;
      this.tag = DATA.fonts.tag;  // a beacon's name
      this.line = this.font.linesize + 2;
      const H = this.hudHeight = Math.max(S.hud_height, 6 + (1 + geom.robots.length) * this.line + 14);
      this.xmin = f.origin[0]; this.ymin = f.origin[1];
      this.xmax = f.origin[0] + f.size[0]; this.ymax = f.origin[1] + f.size[1];
      const margin = Math.max(12, Math.floor(Math.min(w, h) / 30));
      this.scale = Math.min((w - 2 * margin) / f.size[0], (h - H - 2 * margin) / f.size[1]);
      this.ox = (w - f.size[0] * this.scale) / 2 - this.xmin * this.scale;
      this.oy = H + (h - H - f.size[1] * this.scale) / 2 + this.ymax * this.scale;
      this.px = Math.max(1, pyRound(this.scale * 0.004));
    }

    toScreen(x, y) { return [pyRound(this.ox + x * this.scale), pyRound(this.oy - y * this.scale)]; }
    len(metres, least = 2) { return Math.max(least, pyRound(metres * this.scale)); }

    text(ctx, str, font, x, y, c) {  // pygame's blit of rendered text: (x, y) is the top-left corner
      ctx.font = font.css; ctx.fillStyle = rgb(c); ctx.textBaseline = "alphabetic"; ctx.textAlign = "left";
      ctx.fillText(str, x, y + font.ascent);
    }

    draw(ctx, scene) {
      const [w, h] = this.size, px = this.px, FIELD = S.field;
      draw.rect(ctx, S.background, 0, 0, w, h);
      this.field(ctx);
      scene.paths.forEach((path, slot) => {
        if (path.length > 1) {
          const pts = path.map((p) => this.toScreen(...p));
          draw.lines(ctx, mix(colour(slot), FIELD, 0.55), pts, px);
          for (const p of pts) draw.circle(ctx, mix(colour(slot), FIELD, 0.3), p, px + 2);
        }
      });
      for (const r of scene.robots)
        if (r.trail.length > 1) draw.lines(ctx, mix(colour(r.slot), FIELD, 0.35), r.trail.map((p) => this.toScreen(...p)), px);
      for (const [slot, x0, y0, x1, y1] of scene.beams) {
        draw.line(ctx, colour(slot), this.toScreen(x0, y0), this.toScreen(x1, y1), px);
        draw.circle(ctx, colour(slot), this.toScreen(x1, y1), px + 3);
      }
      this.beacons(ctx);
      for (const [slot, d] of scene.drawings) this.drawing(ctx, slot, d);
      for (const r of scene.robots) this.robot(ctx, r);
      this.hud(ctx, scene);
    }

    field(ctx) {
      const [x0, y0] = this.toScreen(this.xmin, this.ymax), [x1, y1] = this.toScreen(this.xmax, this.ymin);
      draw.rect(ctx, S.field, x0, y0, x1 - x0, y1 - y0);
      if (this.geom.field.walls) draw.rect(ctx, S.wall, x0, y0, x1 - x0, y1 - y0, Math.max(2, this.px * 2));
      for (const ob of this.geom.obstacles) {
        if (ob.kind === "circle") draw.circle(ctx, S.obstacle, this.toScreen(...ob.points[0]), this.len(ob.radius));
        else draw.polygon(ctx, S.obstacle, ob.points.map((p) => this.toScreen(...p)));
      }
    }

    beacons(ctx) {
      const kind = this.geom.beacons.kind, r = Math.max(5, this.len(this.geom.beacons.radius));
      const c = S.beacon[kind] || S.beacon.reflector;
      for (const b of this.geom.beacons.items) {
        const [cx, cy] = this.toScreen(b.x, b.y), fx = Math.cos(b.facing), fy = -Math.sin(b.facing);
        if (kind === "light") {
          draw.circle(ctx, mix(c, S.field, 0.6), [cx, cy], r * 2);
          draw.circle(ctx, c, [cx, cy], r);
        } else if (kind === "sensor_array") {  // a bar across its facing direction
          const px = -fy * r * 1.6, py = fx * r * 1.6;
          draw.line(ctx, c, [cx - px, cy - py], [cx + px, cy + py], Math.max(3, Math.floor(r / 2)));
        } else if (kind === "flash_detector") {
          draw.polygon(ctx, c, [[cx, cy - r], [cx + r, cy], [cx, cy + r], [cx - r, cy]]);
        } else {  // a reflector: a triangle pointing where it faces
          draw.polygon(ctx, c, [[cx + fx * r * 1.4, cy + fy * r * 1.4],
                                [cx - fy * r - fx * r * 0.6, cy + fx * r - fy * r * 0.6],
                                [cx + fy * r - fx * r * 0.6, cy - fx * r - fy * r * 0.6]]);
        }
        this.label(ctx, b.id, cx + r + 2, cy - r - 2);
      }
    }

    label(ctx, str, x, bottom) {  // arena/draw.py's _label: a beacon's name on a plate, kept in the frame
      ctx.font = this.tag.css;
      const w = Math.round(ctx.measureText(str).width) + 6, h = this.tag.height + 2;
      x = Math.min(x, this.size[0] - w - 2);
      const y = Math.max(bottom - h, this.hudHeight + 2);
      draw.rect(ctx, S.label_plate, x, y, w, h);
      draw.rect(ctx, S.label, x, y, w, h, 1);
      this.text(ctx, str, this.tag, x + 3, y + 1, S.label);
    }

    box(x, y, h, length, width) {
      const c = Math.cos(h), s = Math.sin(h);
      return [[length / 2, width / 2], [-length / 2, width / 2], [-length / 2, -width / 2], [length / 2, -width / 2]]
        .map(([dx, dy]) => this.toScreen(x + c * dx - s * dy, y + s * dx + c * dy));
    }

    robot(ctx, r) {
      const body = r.stopped ? [130, 130, 130] : colour(r.slot), px = this.px;
      if (r.estimate) {  // the ghost: where the controller believes it is
        const [ex, ey, eh] = r.estimate, ghost = mix(body, S.field, 0.6);
        draw.polygon(ctx, ghost, this.box(ex, ey, eh, r.length, r.width), px);
        const tip = this.toScreen(ex + Math.cos(eh) * r.length * 0.6, ey + Math.sin(eh) * r.length * 0.6);
        draw.line(ctx, ghost, this.toScreen(ex, ey), tip, px);
      }
      draw.polygon(ctx, body, this.box(r.x, r.y, r.heading, r.length, r.width));
      const tip = this.toScreen(r.x + Math.cos(r.heading) * r.length * 0.6, r.y + Math.sin(r.heading) * r.length * 0.6);
      draw.line(ctx, [20, 20, 20], this.toScreen(r.x, r.y), tip, Math.max(2, px));
      const label = String(r.slot), [cx, cy] = this.toScreen(r.x, r.y);
      ctx.font = this.small.css;
      const w = Math.round(ctx.measureText(label).width);
      this.text(ctx, label, this.small, cx - Math.floor(w / 2), cy - Math.floor(this.small.height / 2), [255, 255, 255]);
    }

    drawing(ctx, slot, d) {
      const c = Array.isArray(d.color) ? d.color : colour(slot);
      const pts = (d.points || []).map((p) => this.toScreen(...p));
      if (d.kind === "line" && pts.length > 1) draw.lines(ctx, c, pts, this.px);
      else if (d.kind === "circle" && pts.length) draw.circle(ctx, c, pts[0], this.len(d.radius ?? 0.01), this.px);
      else if (d.kind === "text" && pts.length) this.text(ctx, String(d.text ?? "").slice(0, 80), this.small, ...pts[0], c);
      else for (const p of pts) draw.circle(ctx, c, p, this.px + 2);
    }

    hud(ctx, scene) {
      const [w] = this.size, H = this.hudHeight;
      draw.rect(ctx, [40, 42, 48], 0, 0, w, H);
      scene.hud.slice(0, 1 + this.geom.robots.length).forEach((line, i) => {
        const c = i === 0 ? S.hud_text : mix(colour(i - 1), S.hud_text, 0.45);  // a robot's line in its colour
        this.text(ctx, line, this.font, 10, 6 + i * this.line, c);
      });
      const [now, marks, duration] = scene.timeline, y = H - 6, span = Math.max(duration, 1e-9);
      draw.line(ctx, [110, 110, 120], [10, y], [w - 10, y], 3);
      for (const m of marks) {  // fouls
        const x = 10 + (w - 20) * m / span;
        draw.line(ctx, [240, 80, 60], [x, y - 6], [x, y + 2], 2);
      }
      draw.circle(ctx, [250, 250, 250], [10 + (w - 20) * Math.min(now, span) / span, y], 5);
    }
  }

  // ---- the page: playback, timeline, panel ----
  const canvas = $("view"), ctx = canvas.getContext("2d");
  [canvas.width, canvas.height] = DATA.size;
  const viewer = {
    time: 0, playing: false, speed: 1, duration: 0, ready: false, error: null, scenes: null, painter: null, name: "",
    seek(t) {
      if (!this.scenes) return;
      this.time = Math.min(Math.max(Number(t) || 0, 0), this.duration);
      show();
    },
    play() { if (this.scenes) { if (this.time >= this.duration) this.time = 0; this.playing = true; last = null; show(); } },
    pause() { this.playing = false; show(); },
    setSpeed(v) { this.speed = Number(v); $("speed").value = String(v); },
    toScreen(x, y) { return this.painter ? this.painter.toScreen(x, y) : null; },
    open: (bytes, name) => open(bytes, name),
  };
  window.viewer = viewer;

  function fail(message) {
    viewer.error = message;
    viewer.ready = true;
    $("message").textContent = message;
  }

  async function open(bytes, name) {
    viewer.playing = false;
    let rep;
    try {
      rep = parseReplay(await gunzip(bytes), name);
    } catch (e) {
      const msg = String(e.message || e);
      return fail(msg.startsWith(name) ? msg : `${name}: a truncated or damaged replay, or not a replay (${msg})`);
    }
    const geom = DATA.levels[rep.header.level && rep.header.level.hash];
    if (!geom) {
      const lv = rep.header.level || {};
      return fail(`${name}: its level ${lv.name} (${lv.hash}) is not one this page knows; `
                  + `make a page for it with: laserarena render ${name} --html OUT.html`);
    }
    let scenes;
    try {
      scenes = new Scenes(rep, geom);
      scenes.at(0);
    } catch (e) {  // records that do not fit the level (a robot missing from a frame, a field missing)
      return fail(`${name}: a damaged replay (${e.message || e})`);
    }
    viewer.error = null;
    $("message").textContent = "";
    viewer.scenes = scenes;
    viewer.painter = new Painter(geom, DATA.size);
    viewer.duration = viewer.scenes.duration;
    viewer.time = 0;
    viewer.name = name;
    document.title = `LaserArena replay — ${name}`;
    setupTimeline(rep);
    finalTable(rep);
    viewer.ready = true;
    show();
  }

  function setupTimeline(rep) {
    const slider = $("slider"), marks = $("marks"), d = Math.max(viewer.duration, 1e-9);
    slider.max = String(viewer.duration);
    slider.step = String(1 / viewer.scenes.rate);
    marks.textContent = "";
    $("incidents").textContent = "";
    const mark = (cls, t, title) => {  // a tick on the timeline and a line in the list; both seek there
      const span = document.createElement("span"), item = document.createElement("li");
      span.className = cls;
      span.style.left = `${100 * Math.min(t, d) / d}%`;
      span.title = item.textContent = title;
      item.className = cls;
      for (const el of [span, item]) el.addEventListener("click", () => { viewer.pause(); viewer.seek(t); });
      marks.appendChild(span);
      $("incidents").appendChild(item);
    };
    const incidents = [...rep.fouls.map((f) => ["foul", f.time, `${f.time.toFixed(2)} s: robot ${f.r} ${f.kind} (-${f.penalty})`]),
                       ...rep.faults.map((f) => ["fault", f.time, `${f.time.toFixed(2)} s: robot ${f.r} fault ${f.kind}: ${f.message}`])];
    for (const args of incidents.sort((a, b) => a[1] - b[1])) mark(...args);
    const h = rep.header;
    $("title").textContent = `${viewer.name}: level ${viewer.scenes.geom.name}, seed ${h.seed}${h.ideal ? ", ideal" : ""}, `
      + `${rep.fouls.length} foul(s), ${rep.faults.length} fault(s)`;
  }

  const cell = (row, text, tag = "td") => { const c = document.createElement(tag); c.textContent = text; row.appendChild(c); return c; };
  function table(id, head, rows) {
    const t = $(id);
    t.textContent = "";
    const hr = t.insertRow();
    for (const h of head) cell(hr, h, "th");
    for (const [slot, values] of rows) {
      const r = t.insertRow();
      values.forEach((v, k) => {
        const c = cell(r, v);
        if (k === 0) { const sw = document.createElement("span"); sw.className = "swatch"; sw.style.background = rgb(colour(slot)); c.prepend(sw); }
      });
    }
  }

  function finalTable(rep) {
    const res = rep.result;
    if (!res) { $("end").textContent = "no result recorded"; table("final", [], []); return; }
    $("end").textContent = `ended at ${res.end_time.toFixed(2)} s (${res.end_reason})`;
    table("final", ["robot", "task", "time", "loc.", "penalties", "total"], res.robots.map((r) => [r.slot,
      [`${r.slot} ${r.team}`, ...["task", "time", "localization", "penalties", "total"].map((k) => (r.score[k] ?? 0).toFixed(1))]]));
  }

  function nowTable(scene) {
    const sc = viewer.scenes, rep = sc.rep, t = viewer.time, task = sc.geom.task;
    const byslot = new Map(((rep.result && rep.result.robots) || []).map((r) => [r.slot, r]));
    table("now", ["robot", "x, y (m)", "heading (deg)", "estimate error (mm, deg)", "task", "fouls (points)", "score so far"], scene.robots.map((r) => {
      const e = sc.standings.errorNow(r.slot, t);  // the latest estimate against the truth at its tick
      const err = e ? `${(1000 * e[0]).toFixed(1)}, ${(180 / Math.PI * e[1]).toFixed(1)}` : "none";
      const res = byslot.get(r.slot), done = res && res.task;
      let progress = task.kind;
      if (done && "reached_at" in done) progress = `${done.reached_at.filter((x) => x <= t).length} / ${done.total} reached`;
      else if (task.goal) progress = `${Math.hypot(r.x - task.goal[0], r.y - task.goal[1]).toFixed(3)} m to goal`;
      if (done && done.finished !== null && done.finished <= t) progress += ", finished";
      if (r.stopped) progress += ", stopped";
      const fouls = rep.fouls.filter((f) => f.r === r.slot && f.time <= t);
      const penalty = fouls.reduce((a, f) => a + (f.penalty || 0), 0);
      return [r.slot, [`${r.slot} ${sc.teams[r.slot] ?? ""}`, `${r.x.toFixed(3)}, ${r.y.toFixed(3)}`,
        (180 / Math.PI * remainder(r.heading, TAU)).toFixed(1), err, progress, fouls.length ? `${fouls.length} (-${penalty.toFixed(1)})` : "0",
        sc.standings.score(r.slot, t).toFixed(1)]];
    }));
  }

  function show() {
    if (!viewer.scenes) return;
    const scene = viewer.scenes.at(viewer.time);
    viewer.painter.draw(ctx, scene);
    canvas.dataset.time = viewer.time.toFixed(4);
    $("slider").value = String(viewer.time);
    $("timebox").textContent = `${viewer.time.toFixed(2)} / ${viewer.duration.toFixed(2)} s`;
    $("play").textContent = viewer.playing ? "Pause" : "Play";
    nowTable(scene);
  }

  let last = null;
  function tick(now) {
    if (viewer.playing && viewer.scenes) {
      if (last !== null) viewer.time = Math.min(viewer.time + (now - last) / 1000 * viewer.speed, viewer.duration);
      if (viewer.time >= viewer.duration) viewer.playing = false;
      show();
    }
    last = viewer.playing ? now : null;
    requestAnimationFrame(tick);
  }

  // ---- controls ----
  $("play").addEventListener("click", (e) => {
    e.currentTarget.blur();  // so that space is the page's key, not a second click
    viewer.playing ? viewer.pause() : viewer.play();
  });
  $("speed").addEventListener("change", (e) => viewer.setSpeed(e.target.value));
  $("slider").addEventListener("input", (e) => viewer.seek(e.target.value));
  document.addEventListener("keydown", (e) => {
    if (!viewer.scenes || e.target.tagName === "SELECT" || (e.target.tagName === "INPUT" && e.key !== " ")) return;
    const step = viewer.playing ? 1 : 1 / viewer.scenes.rate;
    const keys = { " ": () => (viewer.playing ? viewer.pause() : viewer.play()), ArrowLeft: () => viewer.seek(viewer.time - step),
                   ArrowRight: () => viewer.seek(viewer.time + step), Home: () => viewer.seek(0), End: () => viewer.seek(viewer.duration) };
    if (keys[e.key]) { e.preventDefault(); keys[e.key](); }
  });
  const openFile = async (file) => open(new Uint8Array(await file.arrayBuffer()), file.name);
  $("file").addEventListener("change", (e) => { if (e.target.files[0]) openFile(e.target.files[0]); });
  document.addEventListener("dragover", (e) => { e.preventDefault(); document.body.classList.add("dragging"); });
  document.addEventListener("dragleave", () => document.body.classList.remove("dragging"));
  document.addEventListener("drop", (e) => {
    e.preventDefault();
    document.body.classList.remove("dragging");
    if (e.dataTransfer.files[0]) openFile(e.dataTransfer.files[0]);
  });

  // ---- start: fonts first (pygame's default font, embedded), then the embedded replay ----
  async function start() {
    for (const f of [DATA.fonts.big, DATA.fonts.small, DATA.fonts.tag]) {
      // pygame's text is wider than its point size says: scale the font so the sample line
      // is as wide as pygame drew it
      const family = "LaserArenaSans, sans-serif";
      try { await document.fonts.load(`${f.size}px ${family}`); } catch (e) { /* the fallback font draws */ }
      ctx.font = `${f.size}px ${family}`;
      const px = f.size * f.sample_width / Math.max(ctx.measureText(f.sample).width, 1);
      f.css = `${px.toFixed(2)}px ${family}`;
    }
    if (typeof DecompressionStream === "undefined") return fail("this browser cannot un-gzip (no DecompressionStream)");
    const bin = atob(DATA.replay), bytes = new Uint8Array(bin.length);
    for (let k = 0; k < bin.length; k++) bytes[k] = bin.charCodeAt(k);
    await open(bytes, DATA.name);
    requestAnimationFrame(tick);
  }
  start();
})();
