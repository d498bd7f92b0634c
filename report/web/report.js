// The report page's script (embedded into ttp at build time).
// Draws the plots and writes, per plot, how many data points landed inside
// the plot area (data-points) so a browser test can check them.
(function(){
"use strict";
var data = JSON.parse(document.getElementById("ttp-data").textContent);
var meta = JSON.parse(document.getElementById("ttp-meta").textContent);
var FIG = ["E_X","E_Y","E_Z","E_B","E_TTP"];
// Series names: a comparison page draws piece A as "measured" and piece B
// in the place of the simulation.
var LBL = meta.labels || { measured: "measured", simulated: "simulated" };
function el(id){ return document.getElementById(id); }
function width(div){ return Math.max(340, div.clientWidth || 360); }
function finite(v){ return v !== null && v !== undefined && isFinite(v); }
// Counts the points of the data series (not limits) that were drawn inside
// the plot area, after uPlot has drawn.
function countHook(series){
  return function(u){
    var n = 0, b = u.bbox;
    series.forEach(function(si){
      var xs = u.data[0], ys = u.data[si];
      for (var i = 0; i < xs.length; i++) {
        if (!finite(ys[i])) continue;
        var x = u.valToPos(xs[i], "x", true), y = u.valToPos(ys[i], u.series[si].scale, true);
        if (x >= b.left - 1 && x <= b.left + b.width + 1 && y >= b.top - 1 && y <= b.top + b.height + 1) n++;
      }
    });
    u.root.parentNode.setAttribute("data-points", String(n));
  };
}
function cutLines(u){
  var ctx = u.ctx, b = u.bbox;
  ctx.save(); ctx.lineWidth = 1; ctx.setLineDash([3, 3]);
  meta.cuts.forEach(function(c){
    var x = u.valToPos(c.t_h, "x", true);
    if (x < b.left || x > b.left + b.width) return;
    ctx.strokeStyle = c.colour; ctx.globalAlpha = 0.55;
    ctx.beginPath(); ctx.moveTo(x, b.top); ctx.lineTo(x, b.top + b.height); ctx.stroke();
  });
  ctx.restore();
}
// One legend entry for the pair of limit lines.
function hideLegend(label){
  return function(u){
    u.root.querySelectorAll(".u-legend .u-series").forEach(function(row){
      if (row.textContent.trim() === label) row.style.display = "none";
    });
  };
}
function byCycle(list){
  var m = {}; (list || []).forEach(function(e){ m[e.cycle] = e; }); return m;
}
function figurePlots(){
  var f = data.figures; if (!f) return;
  var meas = byCycle(f.measured), sim = byCycle(f.simulated), lin = f.simulated_linear ? byCycle(f.simulated_linear) : null;
  var cycles = Object.keys(Object.assign({}, meas, sim)).map(Number).sort(function(a,b){return a-b;});
  FIG.forEach(function(key){
    var div = el("plot-" + key); if (!div) return;
    var lim = key === "E_B" ? meta.limits.angular_um_per_m : meta.limits.linear_um;
    var unit = key === "E_B" ? "um/m" : "um";
    var m = cycles.map(function(c){ return meas[c] ? meas[c][key] : null; });
    var mu = cycles.map(function(c){ return meas[c] && meas[c].U ? meas[c].U[key] : null; });
    var s = cycles.map(function(c){ return sim[c] ? sim[c][key] : null; });
    var su = cycles.map(function(c){ return sim[c] && sim[c].U ? sim[c].U[key] : null; });
    var hi = cycles.map(function(){ return lim; }), lo = cycles.map(function(){ return -lim; });
    var sl = lin ? cycles.map(function(c){ return lin[c] ? lin[c][key] : null; }) : null;
    function whiskers(u){
      var ctx = u.ctx; ctx.save(); ctx.lineWidth = 1.5;
      [[1, mu, "#0b4f8a"], [2, su, "#c2410c"]].forEach(function(w){
        var ys = u.data[w[0]], us = w[1];
        ctx.strokeStyle = w[2];
        for (var i = 0; i < ys.length; i++) {
          if (!finite(ys[i]) || !finite(us[i])) continue;
          var x = u.valToPos(u.data[0][i], "x", true) + (w[0] === 2 ? 4 : 0);
          var y0 = u.valToPos(ys[i] - us[i], "y", true), y1 = u.valToPos(ys[i] + us[i], "y", true);
          ctx.beginPath(); ctx.moveTo(x, y0); ctx.lineTo(x, y1);
          ctx.moveTo(x - 4, y0); ctx.lineTo(x + 4, y0); ctx.moveTo(x - 4, y1); ctx.lineTo(x + 4, y1);
          ctx.stroke();
        }
      });
      ctx.restore();
    }
    var all = m.concat(s, hi, lo, sl || []).filter(finite);
    var ext = Math.max.apply(null, all.map(Math.abs).concat(mu.filter(finite).map(function(u, i){ return 0; })));
    var ymax = Math.max(lim * 1.25, ext * 1.15);
    cycles.forEach(function(c, i){ if (finite(m[i]) && finite(mu[i])) ymax = Math.max(ymax, (Math.abs(m[i]) + mu[i]) * 1.1); });
    new uPlot({
      title: key + " (" + unit + ")", width: width(div), height: 240, legend: { live: false },
      scales: { x: { time: false, range: [cycles[0] - 0.5, cycles[cycles.length - 1] + 0.5] }, y: { range: [-ymax, ymax] } },
      axes: [{ label: "cycle", incrs: [1], values: function(u, v){ return v.map(function(x){ return Number.isInteger(x) ? x : ""; }); } },
             { label: unit, size: 60 }],
      series: [{ label: "cycle" },
        { label: LBL.measured, stroke: "#0b4f8a", width: 0, paths: function(){ return null; }, points: { show: true, size: 9, fill: "#0b4f8a" } },
        { label: LBL.simulated, stroke: "#c2410c", width: 2, points: { show: true, size: 6, fill: "#fff" } },
        { label: "limits", stroke: "#b3261e", width: 1.2, dash: [6, 4], points: { show: false } },
        { label: "-limit", stroke: "#b3261e", width: 1.2, dash: [6, 4], points: { show: false } }].concat(sl ? [
        { label: "simulated, straight line", stroke: "#7b8794", width: 1.2, dash: [2, 3], points: { show: true, size: 4, fill: "#7b8794" } }] : []),
      hooks: { init: [hideLegend("-limit")], draw: [whiskers, countHook(sl ? [1, 2, 5] : [1, 2])] }
    }, [cycles, m, s, hi, lo].concat(sl ? [sl] : []), div);
  });
}
function logPlot(id, title, xs_h, series, axes){
  var div = el(id); if (!div) return;
  var d = [xs_h].concat(series.map(function(s){ return s.values; }));
  var idx = series.map(function(s, i){ return i + 1; });
  new uPlot({
    title: title, width: width(div), height: 260, legend: { live: false },
    scales: Object.assign({ x: { time: false } }, axes.scales || {}),
    axes: [{ label: "time since log start (h)" }].concat(axes.list),
    series: [{ label: "t (h)" }].concat(series.map(function(s){
      return { label: s.label, stroke: s.colour, width: s.width || 1.5, scale: s.scale || "y",
               paths: s.stepped ? uPlot.paths.stepped({ align: 1 }) : undefined,
               points: { show: !!s.points, size: 5, fill: s.colour }, spanGaps: !!s.points };
    })),
    hooks: { draw: [cutLines, countHook(idx)] }
  }, d, div);
}
function logPlots(){
  var log = data.log; if (!log) return;
  var palette = ["#0b4f8a", "#c2410c", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#17becf"];
  if (log.samples) {
    var sm = log.samples, th = sm.t_s.map(function(t){ return t / 3600; });
    var temps = [];
    [["T_env", "T_env (degC)"], ["T_ws", "T_ws (degC)"], ["T_mwf", "T_mwf (degC)"]].forEach(function(c, i){
      if (sm[c[0]]) temps.push({ label: c[1], values: sm[c[0]], colour: palette[i] });
    });
    if (sm.dT_cool) temps.push({ label: "dT_cool (K)", values: sm.dT_cool, colour: palette[3], scale: "K" });
    logPlot("plot-temperatures", "Temperatures", th, temps,
      { list: [{ label: "degC", size: 60 }, { label: "K", scale: "K", side: 1, size: 50, grid: { show: false } }] });
    var speed = [];
    if (sm.c_rpm) speed.push({ label: "C speed (1/min)", values: sm.c_rpm, colour: palette[0], stepped: true });
    logPlot("plot-c-speed", "C-axis speed", th, speed, { list: [{ label: "1/min", size: 60 }] });
  }
  if (log.rtests) {
    var rt = log.rtests, rh = rt.t_s.map(function(t){ return t / 3600; });
    var lin = [], ang = [];
    ["EX0C", "EY0C", "EZ0T", "ER0T"].forEach(function(k, i){
      if (rt[k]) lin.push({ label: k + " (um)", values: rt[k], colour: palette[i], points: true });
    });
    ["EA0C", "EB0C", "EC0C"].forEach(function(k, i){
      if (rt[k]) ang.push({ label: k + " (um/m)", values: rt[k], colour: palette[i + 4], points: true });
    });
    logPlot("plot-rtest-linear", "R-test: linear errors of the C axis", rh, lin, { list: [{ label: "um", size: 60 }] });
    logPlot("plot-rtest-angular", "R-test: angular errors of the C axis", rh, ang, { list: [{ label: "um/m", size: 60 }] });
  }
}
function residualPlots(){
  var r = data.diagnosis && data.diagnosis.residuals; if (!r) return;
  var keys = ["E_X", "E_Y", "E_Z", "E_TTP"], colours = ["#0b4f8a", "#c2410c", "#2ca02c", "#9467bd"];
  var present = keys.filter(function(k){ return r.before[k]; });
  var ymax = 0.5;
  ["before", "after"].forEach(function(w){ present.forEach(function(k){ (r[w][k] || []).forEach(function(v, i){
    if (finite(v)) ymax = Math.max(ymax, 1.15 * (Math.abs(v) + (r.sigma && r.sigma[k] && finite(r.sigma[k][i]) ? r.sigma[k][i] : 0)));
  }); }); });
  [["before", "Before: nominal model"], ["after", "After: with the fitted effect"]].forEach(function(w){
    var div = el("plot-residual-" + w[0]); if (!div) return;
    var d = [r.cycles].concat(present.map(function(k){ return r[w[0]][k]; }));
    function bars(u){
      if (!r.sigma) return;
      var ctx = u.ctx; ctx.save(); ctx.lineWidth = 1.2;
      present.forEach(function(k, s){
        var ys = u.data[s + 1], us = r.sigma[k] || []; ctx.strokeStyle = colours[keys.indexOf(k)];
        for (var i = 0; i < ys.length; i++) {
          if (!finite(ys[i]) || !finite(us[i])) continue;
          var x = u.valToPos(u.data[0][i], "x", true) + (s - 1.5) * 4;
          var y0 = u.valToPos(ys[i] - us[i], "y", true), y1 = u.valToPos(ys[i] + us[i], "y", true);
          ctx.beginPath(); ctx.moveTo(x, y0); ctx.lineTo(x, y1); ctx.stroke();
        }
      });
      ctx.restore();
    }
    new uPlot({
      title: w[1] + " (um)", width: width(div), height: 240, legend: { live: false },
      scales: { x: { time: false, range: [r.cycles[0] - 0.5, r.cycles[r.cycles.length - 1] + 0.5] }, y: { range: [-ymax, ymax] } },
      axes: [{ label: "cycle", incrs: [1], values: function(u, v){ return v.map(function(x){ return Number.isInteger(x) ? x : ""; }); } },
             { label: "um", size: 60 }],
      series: [{ label: "cycle" }].concat(present.map(function(k){
        var c = colours[keys.indexOf(k)];
        return { label: k, stroke: c, width: 1, dash: [2, 3], points: { show: true, size: 7, fill: c } };
      })),
      hooks: { draw: [bars, countHook(present.map(function(k, i){ return i + 1; }))] }
    }, d, div);
  });
}
try { figurePlots(); logPlots(); residualPlots(); }
catch (e) { reportError(String(e && e.stack || e)); }
document.body.setAttribute("data-plots-done", "1");
})();
