// The server's streaming pipeline in the browser (spotfree.ride.live.pipeline_spec gives the numbers): the ride's mount
// (nominal until the tracker decides; a new segment where it changes), device-to-vehicle axes, attitude filter
// (GravityPI or the paper's PI filter), gravity-free level accelerations through a 3rd-order Butterworth, lean,
// speed-aided longitudinal acceleration, the model's channels scaled into a ring buffer, each due window represented
// (summary models), and CRC_RLS on it: r_i = ||E_i y||, label = argmin_i r_i (kernel CRC_RLS: the same on the window's
// Nystroem features). Same operations in the same order as spotfree.signal.* and spotfree.classify.stream, so labels
// are equal. Units: m/s^2, rad/s, s; device frame of Android (x right, y up, z out of the screen).
"use strict";

(function (root) {
  const TWO_PI = 2 * Math.PI;

  function rotate(ux, uy, uz, wx, wy, wz, dt) {
    // body coordinates of a world-fixed vector after turning at w (rad/s) for dt (s): Rodrigues' formula
    const norm = Math.sqrt(wx * wx + wy * wy + wz * wz);
    const angle = norm * dt;
    if (angle < 1e-12) return [ux, uy, uz];
    const kx = -wx / norm, ky = -wy / norm, kz = -wz / norm;
    const c = Math.cos(angle), s = Math.sin(angle);
    const d = (kx * ux + ky * uy + kz * uz) * (1.0 - c);
    return [
      ux * c + (ky * uz - kz * uy) * s + kx * d,
      uy * c + (kz * ux - kx * uz) * s + ky * d,
      uz * c + (kx * uy - ky * ux) * s + kz * d,
    ];
  }

  function smoothing(dt, tau) {
    // weight of a new sample in a first-order low-pass of time constant tau (s); 1 without smoothing
    return tau > 0 ? 1.0 - Math.exp(-dt / tau) : 1.0;
  }

  class GravityPI {
    constructor(p, rate) { this.p = p; this.rate = rate; this.reset(); }
    reset() { this.u = null; this.bias = [0, 0, 0]; this.still = 0; this.f = null; this.motion = 0; this.age = 0; }
    update(acc, gyr) {
      const p = this.p;
      const ax = acc[0], ay = acc[1], az = acc[2];
      const normA = Math.sqrt(ax * ax + ay * ay + az * az);
      if (this.u === null) this.u = normA > 0 ? [ax / normA, ay / normA, az / normA] : [0, 0, 1];
      if (this.f === null) this.f = [ax, ay, az];
      const b = this.bias;
      const wx = gyr[0] - b[0], wy = gyr[1] - b[1], wz = gyr[2] - b[2];
      const half = 0.5 / this.rate;
      let [ux, uy, uz] = rotate(this.u[0], this.u[1], this.u[2], wx, wy, wz, half);
      const w2 = wx * wx + wy * wy + wz * wz;
      const departure = normA - p.g;
      // accelerometer low-passed where gravity is fixed, longer while the phone is shaken
      this.motion += smoothing(2.0 * half, p.motion_tau) * (Math.abs(departure) - this.motion);
      const shaken = (this.motion / p.acc_scale) ** 2;
      let [fx, fy, fz] = rotate(this.f[0], this.f[1], this.f[2], wx, wy, wz, 2.0 * half);
      const alpha = smoothing(2.0 * half, p.acc_tau * shaken / (1.0 + shaken));
      fx += alpha * (ax - fx); fy += alpha * (ay - fy); fz += alpha * (az - fz);
      this.f = [fx, fy, fz];
      const normF = Math.sqrt(fx * fx + fy * fy + fz * fz);
      if (w2 < p.rest_gyr * p.rest_gyr && Math.abs(departure) < p.rest_acc) this.still += 2.0 * half;
      else this.still = 0.0;
      if (normF > 0) {
        const nx = fx / normF, ny = fy / normF, nz = fz / normF;
        const ex = ny * uz - nz * uy, ey = nz * ux - nx * uz, ez = nx * uy - ny * ux;
        let k;
        if (this.still >= p.rest_time) {
          k = p.rest_gain;
          const step = 2.0 * half / p.rest_tau;
          b[0] += step * wx; b[1] += step * wy; b[2] += step * wz;
        } else if (this.age < p.startup_time) {
          // start-up: a ramped-down gain, unbounded, no integral term
          k = Math.max(p.kp, p.startup_gain * (1.0 - this.age / p.startup_time));
          k *= Math.sqrt((1.0 + w2 / p.rate_scale ** 2) / (1.0 + shaken));
        } else {
          const trust = Math.sqrt((1.0 + w2 / p.rate_scale ** 2) / (1.0 + shaken));
          k = p.kp * trust;
          const sine = Math.sqrt(ex * ex + ey * ey + ez * ez);
          const limit = Math.sin(p.max_error);
          if (sine > limit) k *= limit / sine;
          const integral = p.ki * (k / p.kp) * 2.0 * half;
          b[0] -= integral * ex; b[1] -= integral * ey; b[2] -= integral * ez;
        }
        [ux, uy, uz] = rotate(ux, uy, uz, k * ex, k * ey, k * ez, 2.0 * half);
      }
      [ux, uy, uz] = rotate(ux, uy, uz, wx, wy, wz, half);
      const normU = Math.sqrt(ux * ux + uy * uy + uz * uz);
      this.u = [ux / normU, uy / normU, uz / normU];
      this.age += 2.0 * half;
      return [Math.atan2(this.u[1], this.u[2]), Math.atan2(-this.u[0], Math.hypot(this.u[1], this.u[2]))];
    }
  }

  function pyRound(x) {
    // Python's round(): half to even
    const r = Math.round(x);
    return (Math.abs(x % 1) === 0.5 && r % 2 !== 0) ? r - 1 : r;
  }

  function wrap(angle) {
    const m = (angle + Math.PI) % TWO_PI;
    return (m < 0 ? m + TWO_PI : m) - Math.PI;
  }

  class PaperAttitude {
    constructor(p) { this.p = p; this.reset(); }
    reset() { this.state = null; this.rollPrev = null; this.turns = 0.0; }
    update(acc, gyr) {
      const p = this.p;
      const rollAcc = Math.atan2(acc[1], acc[2]);
      const pitchAcc = Math.atan2(-acc[0], Math.hypot(acc[1], acc[2]));
      if (this.rollPrev !== null) this.turns -= pyRound((rollAcc - this.rollPrev) / TWO_PI) * TWO_PI;
      this.rollPrev = rollAcc;
      const xs = [rollAcc + this.turns, pitchAcc];
      if (this.state === null) this.state = xs.map((x) => [p.zi[0] * x, p.zi[1] * x]);
      const out = [];
      for (let j = 0; j < 2; j++) {
        const s = this.state[j], x = xs[j], w = gyr[j];
        const y = p.b_rate[0] * w + p.b_acc[0] * x + s[0];
        s[0] = p.b_rate[1] * w + p.b_acc[1] * x - p.a[1] * y + s[1];
        s[1] = p.b_rate[2] * w + p.b_acc[2] * x - p.a[2] * y;
        out.push(y);
      }
      return [wrap(out[0]), out[1]];
    }
  }

  class Lowpass {
    constructor(spec, channels) { this.spec = spec; this.channels = channels; this.reset(); }
    reset() { this.state = null; }
    update(x) {
      const { sections, zi } = this.spec;
      if (this.state === null) this.state = x.map((v) => zi.flatMap((pair) => pair.map((z) => z * v)));
      const out = [];
      for (let c = 0; c < x.length; c++) {
        const z = this.state[c];
        let v = x[c], i = 0;
        for (const [b0, b1, b2, a1, a2] of sections) {
          const y = b0 * v + z[i];
          z[i] = b1 * v - a1 * y + z[i + 1];
          z[i + 1] = b2 * v - a2 * y;
          v = y;
          i += 2;
        }
        out.push(v);
      }
      return out;
    }
  }

  class SpeedAidedPitch {
    constructor(p, rate) { this.p = p; this.rate = rate; this.reset(); }
    reset() { this.x = null; this.P = [0, 0, 0, 0, 0, 0]; this.hasSpeed = false; }
    update(acc, gyr, roll, pitchRef, speed) {
      const par = this.p, dt = 1.0 / this.rate;
      const ax = acc[0], ay = acc[1], az = acc[2], q = gyr[1], r = gyr[2];
      const sr = Math.sin(roll), cr = Math.cos(roll);
      const across = sr * ay + cr * az;
      if (this.x === null) {
        this.x = [pitchRef, 0.0, 0.0];
        this.P = [par.initial_pitch ** 2, 0.0, 0.0, par.initial_bias ** 2, 0.0, par.initial_speed ** 2];
      }
      const [theta, bias, v] = this.x;
      const st = Math.sin(theta), ct = Math.cos(theta);
      const aT = ct * ax + st * across;
      const s = (-st * ax + ct * across) * dt;
      const [p00, p01, p02, p11, p12, p22] = this.P;
      this.P = [
        p00 - 2 * dt * p01 + dt * dt * p11 + par.pitch_noise ** 2 * dt,
        p01 - dt * p11,
        s * (p00 - dt * p01) + p02 - dt * p12,
        p11 + par.bias_noise ** 2 * dt,
        s * p01 + p12,
        s * s * p00 + 2 * s * p02 + p22 + (par.accel_noise * dt) ** 2,
      ];
      this.x = [theta + (q * cr - r * sr - bias) * dt, bias, v + aT * dt];
      this.measure(0, pitchRef - this.x[0], par.reference_noise ** 2 / dt);
      if (speed === speed) {
        if (!this.hasSpeed) {
          const P = this.P;
          this.x = [this.x[0], this.x[1], speed];
          this.P = [P[0], P[1], 0.0, P[3], 0.0, 0.0];
          this.hasSpeed = true;
        }
        this.measure(2, speed - this.x[2], par.speed_noise ** 2);
      }
      const th = this.x[0];
      return Math.cos(th) * ax + Math.sin(th) * across;
    }
    measure(k, innovation, variance) {
      const [p00, p01, p02, p11, p12, p22] = this.P;
      const [c0, c1, c2] = k === 0 ? [p00, p01, p02] : [p02, p12, p22];
      const inv = 1.0 / ((k === 0 ? c0 : c2) + variance);
      const [x0, x1, x2] = this.x;
      this.x = [x0 + c0 * inv * innovation, x1 + c1 * inv * innovation, x2 + c2 * inv * innovation];
      this.P = [p00 - c0 * c0 * inv, p01 - c0 * c1 * inv, p02 - c0 * c2 * inv,
        p11 - c1 * c1 * inv, p12 - c1 * c2 * inv, p22 - c2 * c2 * inv];
    }
  }


  // ---- the mount (spotfree.signal.mount): running sums of the ride, and the live ride's decisions on them

  function dot(u, v) { return u[0] * v[0] + u[1] * v[1] + u[2] * v[2]; }
  function cross(u, v) { return [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]]; }
  function unit(v) { const n = Math.sqrt(dot(v, v)); return [v[0] / n, v[1] / n, v[2] / n]; }
  function horizontal(v, up) { const k = dot(v, up); return [v[0] - k * up[0], v[1] - k * up[1], v[2] - k * up[2]]; }

  class MountStatistics {
    // MountStatistics of spotfree.signal.mount: quiet-sample force sums, leaky lean, and per speed-change interval
    // (GPS fixes at least min_interval s apart) the sums of d, c, d^2, c^2, d c and of x, x d, x c, x x^T of each
    // cue x (the turn c the centripetal acceleration)
    constructor(p, rate, g) {
      this.p = p; this.rate = rate; this.g = g;
      this.leanC = Math.exp(-1.0 / (p.lean_time_constant * rate));
      this.valid = 0; this.quiet = 0; this.force = [0, 0, 0]; this.quietForce = [0, 0, 0]; this.lean = [0, 0, 0];
      this.fix = null; this.inside = 0; this.insideSums = new Array(9).fill(0);
      this.n = 0; this.d = 0.0; this.dd = 0.0; this.c = 0.0; this.cc = 0.0; this.dc = 0.0;
      this.x = [[0, 0, 0], [0, 0, 0]]; this.xd = [[0, 0, 0], [0, 0, 0]]; this.xc = [[0, 0, 0], [0, 0, 0]];
      this.xx = [new Array(9).fill(0), new Array(9).fill(0)];
    }
    update(t, acc, gyr, speed) {
      // true when the sample closed a speed-change interval
      const p = this.p, c = this.leanC, lean = this.lean;
      const [a0, a1, a2] = acc, [w0, w1, w2] = gyr;
      if (![a0, a1, a2, w0, w1, w2].every(Number.isFinite)) {
        lean[0] = c * lean[0]; lean[1] = c * lean[1]; lean[2] = c * lean[2];
        return false;
      }
      const step = 1.0 / this.rate;
      lean[0] = c * lean[0] + w0 * step; lean[1] = c * lean[1] + w1 * step; lean[2] = c * lean[2] + w2 * step;
      this.valid += 1;
      const f = this.force;
      f[0] += a0; f[1] += a1; f[2] += a2;
      const normA = Math.sqrt(a0 * a0 + a1 * a1 + a2 * a2);
      if (Math.sqrt(w0 * w0 + w1 * w1 + w2 * w2) < p.quiet_rate && Math.abs(normA - this.g) < p.quiet_force) {
        this.quiet += 1;
        const q = this.quietForce;
        q[0] += a0; q[1] += a1; q[2] += a2;
      }
      const s = this.insideSums;
      [a0, a1, a2, lean[0], lean[1], lean[2], w0, w1, w2].forEach((v, k) => { s[k] += v; });
      this.inside += 1;
      if (!Number.isFinite(speed)) return false;
      if (this.fix === null || t <= this.fix[0]) { this.open(t, speed); return false; }
      if (t - this.fix[0] < p.min_interval) return false;
      const d = (speed - this.fix[1]) / (t - this.fix[0]);
      const g = this.quiet > 0 ? this.quietForce : this.force;
      const yaw = (g[0] * s[6] + g[1] * s[7] + g[2] * s[8]) / (this.inside * Math.sqrt(g[0] * g[0] + g[1] * g[1]
        + g[2] * g[2]));
      const turn = 0.5 * (speed + this.fix[1]) * yaw;
      this.n += 1; this.d += d; this.dd += d * d; this.c += turn; this.cc += turn * turn; this.dc += d * turn;
      for (let cue = 0; cue < 2; cue++) {
        const x = [0, 1, 2].map((k) => s[3 * cue + k] / this.inside);
        const sx = this.x[cue], sxd = this.xd[cue], sxc = this.xc[cue], sxx = this.xx[cue];
        for (let i = 0; i < 3; i++) {
          sx[i] += x[i];
          sxd[i] += x[i] * d;
          sxc[i] += x[i] * turn;
          for (let j = 0; j < 3; j++) sxx[3 * i + j] += x[i] * x[j];
        }
      }
      this.open(t, speed);
      return true;
    }
    open(t, speed) { this.fix = [t, speed]; this.inside = 0; this.insideSums = new Array(9).fill(0); }
    up() { return unit(this.quietForce); }
    forward(up) {
      // the forward direction the speed changes tell (null when they do not)
      const p = this.p, n = this.n;
      if (n < p.min_intervals) return null;
      const sdd = this.dd - this.d * this.d / n;
      if (sdd <= 0 || Math.sqrt(sdd / n) < p.min_speed_change) return null;
      const scc = this.cc - this.c * this.c / n, sdc = this.dc - this.d * this.c / n;
      const turns = scc > 0 && sdd * scc - sdc * sdc > 0;
      let best = null, bestR = -Infinity;
      for (let cue = 0; cue < 2; cue++) {
        const sx = this.x[cue], sxd = this.xd[cue].map((v, i) => v - sx[i] * this.d / n);
        const sxc = this.xc[cue].map((v, i) => v - sx[i] * this.c / n);
        const sxx = this.xx[cue].map((v, k) => v - sx[Math.floor(k / 3)] * sx[k % 3] / n);
        const w = horizontal(turns ? sxd.map((v, i) => v * scc - sxc[i] * sdc) : sxd, up), size = Math.sqrt(dot(w, w));
        if (size === 0) continue;
        const u = [w[0] / size, w[1] / size, w[2] / size];
        let zd = dot(u, sxd), zz = 0.0, dd = sdd;
        const zc = dot(u, sxc);
        for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) zz += u[i] * sxx[3 * i + j] * u[j];
        if (turns) { zd -= zc * sdc / scc; zz -= zc * zc / scc; dd = sdd - sdc * sdc / scc; }
        if (zz <= 0) continue;
        const r = zd / Math.sqrt(zz * dd);
        if (r > bestR) { best = cue === 0 ? u : unit(cross(u, up)); bestR = r; }
      }
      if (bestR <= 0 || (1.0 - bestR * bestR) ** ((n - 4) / 2) >= p.significance) return null;
      return best;
    }
  }

  function topEdgeForward(up) {
    // the horizontal part of y - z (top edge flat, back upright), of y + z when that vanishes
    for (const guess of [[0, 1, -1], [0, 1, 1]]) {
      const h = horizontal(guess, up);
      if (Math.sqrt(dot(h, h)) > 0.1) return unit(h);
    }
    return unit(horizontal([1, 0, 0], up));
  }

  class MountTracker {
    // MountTracker of spotfree.signal.mount: the nominal mount until live_quiet_seconds of quiet samples, then the
    // estimate (used when it is more than usual_angle from the nominal); forward from the top edge until the GPS
    // speed tells it, then final. update() is true when the mount used changes at this sample.
    constructor(p, rate, g, nominal) {
      this.p = p; this.rate = rate; this.nominal = nominal;
      this.statistics = new MountStatistics(p, rate, g);
      this.used = nominal; this.estimated = null; this.angle = 0.0; this.stage = "nominal";
    }
    update(t, acc, gyr, speed) {
      if (this.stage === "final") return false;
      const stats = this.statistics;
      const closed = stats.update(t, acc, gyr, speed);
      if (this.stage === "nominal" && stats.quiet >= this.p.live_quiet_seconds * this.rate) return this.decide();
      if (this.stage === "vertical" && closed && stats.forward(stats.up()) !== null) return this.decide();
      return false;
    }
    decide() {
      const up = this.statistics.up();
      let forward = this.statistics.forward(up);
      this.stage = forward === null ? "vertical" : "final";
      if (forward === null) forward = topEdgeForward(up);
      const estimated = [forward, cross(up, forward), up], M = this.nominal;
      let trace = 0.0;
      for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) trace += estimated[i][j] * M[i][j];
      this.angle = Math.acos(Math.min(Math.max((trace - 1) / 2, -1.0), 1.0));
      const used = this.angle > this.p.usual_angle ? estimated : M;
      const changed = used.some((row, i) => row.some((v, j) => v !== this.used[i][j]));
      this.estimated = estimated;
      this.used = used;
      return changed;
    }
  }

  class FeatureStream {
    // roll, pitch, pitch_rate, acc_x, acc_y, acc_z, lean, acc_long (spotfree.signal.features, derived=True), on the
    // device-to-vehicle axes mount (spec.mount, the nominal one, when not given)
    constructor(spec, mount) {
      this.spec = spec;
      this.mount = mount || spec.mount;
      const att = spec.attitude;
      this.attitude = att.kind === "paper" ? new PaperAttitude(att) : new GravityPI(att, spec.rate);
      this.lowpass = new Lowpass(spec.lowpass, 3);
      this.longLowpass = new Lowpass(spec.long_lowpass, 1);
      this.speedAided = new SpeedAidedPitch(spec.speed_aided, spec.rate);
      this.reset();
    }
    reset() {
      this.attitude.reset(); this.lowpass.reset(); this.speedAided.reset(); this.longLowpass.reset();
      this.lean = 0.0; this.bias = 0.0;
    }
    update(acc, gyr, speed) {
      const m = this.mount, g = this.spec.gravity, L = this.spec.lean;
      const a0 = acc[0], a1 = acc[1], a2 = acc[2], w0 = gyr[0], w1 = gyr[1], w2 = gyr[2];
      const accV = [m[0][0] * a0 + m[0][1] * a1 + m[0][2] * a2, m[1][0] * a0 + m[1][1] * a1 + m[1][2] * a2,
        m[2][0] * a0 + m[2][1] * a1 + m[2][2] * a2];
      const gyrV = [m[0][0] * w0 + m[0][1] * w1 + m[0][2] * w2, m[1][0] * w0 + m[1][1] * w1 + m[1][2] * w2,
        m[2][0] * w0 + m[2][1] * w1 + m[2][2] * w2];
      const [roll, pitch] = this.attitude.update(accV, gyrV);
      const cr = Math.cos(roll), sr = Math.sin(roll), cp = Math.cos(pitch), sp = Math.sin(pitch);
      const across = sr * accV[1] + cr * accV[2];
      const level = this.lowpass.update([cp * accV[0] + sp * across, cr * accV[1] - sr * accV[2],
        -sp * accV[0] + cp * across - g]);
      this.bias = L.c * this.bias + (1.0 - L.c) * gyrV[1];
      this.lean = L.a * this.lean + L.b * (gyrV[1] - this.bias);
      const aT = this.speedAided.update(accV, gyrV, roll, pitch, speed);
      const [accLong] = this.longLowpass.update([aT]);
      return [roll, pitch, gyrV[1], level[0], level[1], level[2], this.lean, accLong];
    }
  }

  class Pipeline {
    // one ride, sample by sample: update(t, acc, gyr, speed) -> {features, label}
    constructor(spec) {
      this.spec = spec;
      this.mount = new MountTracker(spec.mount_tracker, spec.rate, spec.gravity, spec.mount);
      this.features = new FeatureStream(spec);
      const c = spec.channels.length, L = spec.window;
      this.d = c * L;
      this.buffer = spec.channels.map(() => new Float64Array(2 * L));
      this.y = new Float64Array(this.d + (spec.affine !== 0 ? 1 : 0)).fill(spec.affine);
      this.operator = Float64Array.from(spec.operator);
      if (spec.kernel) {
        this.landmarks = Float64Array.from(spec.kernel.landmarks);
        this.normalisation = Float64Array.from(spec.kernel.normalisation);
      }
      this.time = null;
      this.hold = Math.round(spec.mount_history * spec.rate);
      this.history = [];
      this.resetSegment();
    }
    resetSegment() { this.features.reset(); this.history = []; this.resetWindows(); }
    resetWindows() { this.position = 0; this.count = 0; this.label = null; }
    remount(mount) {
      // features and windows on the new mount from the start of the segment: the samples held run again through
      // them, their labels dropped (spotfree.ride.live.LiveRide._remount)
      this.features = new FeatureStream(this.spec, mount);
      this.resetWindows();
      for (const [, acc, gyr, speed] of this.history.slice(-this.hold)) {
        this.push(this.features.update(acc, gyr, speed));
      }
    }
    update(t, acc, gyr, speed) {
      const values = [...acc, ...gyr];
      const finite = values.every(Number.isFinite);
      speed = speed === null || speed === undefined ? NaN : speed;
      const previous = this.time;
      this.time = t;
      const jump = previous !== null && !(t - previous > 0 && t - previous <= this.spec.max_gap);
      if (jump || !finite) this.resetSegment();
      if (this.mount.update(t, acc, gyr, speed)) this.remount(this.mount.used);
      if (!finite) return { features: null, label: null };
      const feats = this.features.update(acc, gyr, speed);
      if (this.mount.stage === "final") this.history = [];
      else {
        // held while the mount may still change: the last mount_history s
        this.history.push([t, acc, gyr, speed]);
        if (this.history.length > 2 * this.hold) this.history = this.history.slice(-this.hold);
      }
      return { features: feats, label: this.push(feats) };
    }
    push(feats) {
      const s = this.spec, L = s.window, p = this.position;
      this.count += 1;
      let due = this.count - L;
      due = due >= 0 && due % s.step === 0;
      for (let i = 0; i < s.pick.length; i++) {
        const v = feats[s.pick[i]] / s.scale[i];
        this.buffer[i][p] = v;
        this.buffer[i][p + L] = v;
      }
      this.position = (p + 1) % L;
      if (due) {
        let k = 0, norm2 = 0.0;
        for (let i = 0; i < s.pick.length; i++) {
          for (let j = p + 1; j < p + 1 + L; j++) {
            this.y[k] = this.buffer[i][j];
            norm2 += this.y[k] * this.y[k];
            k++;
          }
        }
        if (s.normalisation === "unit" && norm2 > 0) {
          const norm = Math.sqrt(norm2);
          for (k = 0; k < this.d; k++) this.y[k] /= norm;
        }
        this.label = this.classify(s.summary ? this.summarise(this.y) : this.y);
      }
      return this.label;
    }
    summarise(y) {
      // summary representation (spotfree.representation): per channel mean, std, min, max, the change of mean and
      // of std from the older to the newer L/2 samples, and the log power of the tapered, mean-removed window in each
      // band, log(1 + sum_{k in band} |X_k|^2 / L); then standardised
      const S = this.spec.summary, c = this.spec.channels.length, L = this.spec.window, bins = S.band.length;
      const half = Math.floor(L / 2), width = 6 + S.bands, z = new Float64Array(c * width), v = new Float64Array(L);
      for (let i = 0; i < c; i++) {
        let total = 0.0, low = Infinity, high = -Infinity, older = 0.0, newer = 0.0;
        for (let t = 0; t < L; t++) {
          const x = y[i * L + t];
          total += x;
          low = Math.min(low, x);
          high = Math.max(high, x);
          if (t < half) older += x;
          if (t >= L - half) newer += x;
        }
        const mean = total / L, n = Math.max(half, 1);
        older /= n;
        newer /= n;
        let variance = 0.0, olderVar = 0.0, newerVar = 0.0;
        for (let t = 0; t < L; t++) {
          const x = y[i * L + t], e = x - mean;
          variance += e * e;
          v[t] = e * S.taper[t];
          if (t < half) olderVar += (x - older) * (x - older);
          if (t >= L - half) newerVar += (x - newer) * (x - newer);
        }
        const o = i * width;
        z[o] = mean; z[o + 1] = Math.sqrt(variance / L); z[o + 2] = low; z[o + 3] = high;
        z[o + 4] = newer - older;
        z[o + 5] = Math.sqrt(newerVar / n) - Math.sqrt(olderVar / n);
        for (let k = 0; k < bins; k++) {
          let re = 0.0, im = 0.0;
          for (let t = 0; t < L; t++) { re += S.cos[k * L + t] * v[t]; im += S.sin[k * L + t] * v[t]; }
          z[o + 6 + S.band[k]] += (re * re + im * im) / L;
        }
        for (let b = 0; b < S.bands; b++) z[o + 6 + b] = Math.log1p(z[o + 6 + b]);
      }
      for (let j = 0; j < z.length; j++) z[j] = (z[j] - S.offset[j]) / S.scale[j];
      return z;
    }
    kernelFeatures(y) {
      // kernel CRC_RLS: phi = N exp(-gamma ||y - l_a||^2)_a (Nystroem features on the model's landmarks)
      const K = this.spec.kernel, m = K.m, d = y.length, L = this.landmarks, N = this.normalisation;
      const k = new Float64Array(m);
      for (let a = 0; a < m; a++) {
        let s = 0.0;
        for (let j = 0; j < d; j++) { const e = y[j] - L[a * d + j]; s += e * e; }
        k[a] = Math.exp(-K.gamma * s);
      }
      const phi = new Float64Array(K.features);
      for (let r = 0; r < K.features; r++) {
        let s = 0.0;
        for (let a = 0; a < m; a++) s += N[r * m + a] * k[a];
        phi[r] = s;
      }
      return phi;
    }
    classify(window) {
      // CRC_RLS: argmin_i ||E_i y||, rejection on min_i r_i / ||y|| when the model sets it; kernel CRC_RLS: the same
      // on the features phi of the window, the rejection on sqrt(min_i ||E_i phi||^2 + 1 - ||phi||^2)
      const y = this.spec.kernel ? this.kernelFeatures(window) : window;
      const D = y.length, C = this.spec.classes.length, E = this.operator;
      let norm2 = 0.0;
      for (let j = 0; j < D; j++) norm2 += y[j] * y[j];
      let best = 0, bestR2 = Infinity;
      for (let c = 0; c < C; c++) {
        let r2 = 0.0;
        for (let i = c * D; i < (c + 1) * D; i++) {
          let e = 0.0;
          const row = i * D;
          for (let j = 0; j < D; j++) e += E[row + j] * y[j];
          r2 += e * e;
        }
        if (r2 < bestR2) { best = c; bestR2 = r2; }
      }
      const reject = this.spec.reject;
      if (reject !== null && reject !== undefined) {
        const ratio = this.spec.kernel ? Math.sqrt(Math.max(bestR2 + 1.0 - norm2, 0.0))
          : norm2 > 0 ? Math.sqrt(bestR2 / norm2) : Infinity;
        if (ratio > reject) return "unknown";
      }
      return this.spec.classes[best];
    }
  }

  class Resampler {
    // DeviceMotion events (any rate) to a uniform grid of 1/rate s: the mean of the events within half a period
    // of each grid time (as spotfree.ride.sensorpush.PushResampler)
    constructor(rate) { this.period = 1.0 / rate; this.slot = null; this.sum = null; this.n = 0; }
    add(t, values) {
      const slot = Math.floor(t / this.period + 0.5);
      const out = [];
      if (this.slot !== null && slot !== this.slot && this.n > 0) {
        out.push([this.slot * this.period, ...this.sum.map((v) => v / this.n)]);
        this.n = 0;
      }
      if (this.n === 0) { this.slot = slot; this.sum = values.map(() => 0); }
      values.forEach((v, i) => { this.sum[i] += v; });
      this.n += 1;
      return out;
    }
  }

  root.spotfreePipeline = { Pipeline, FeatureStream, MountTracker, Resampler };
  if (typeof module !== "undefined") module.exports = root.spotfreePipeline;
})(typeof window !== "undefined" ? window : globalThis);
