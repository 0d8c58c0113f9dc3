// unfold's linked viewer (src/app/cohort/linked_viewer.rs writes the data):
// the flat image and the scan side by side; a click on either marks the same
// point on the other through the precomputed tables. No library, no fetch.
(function () {
  "use strict";
  function bytes(s) {
    var b = atob(s), u = new Uint8Array(b.length);
    for (var i = 0; i < b.length; i++) u[i] = b.charCodeAt(i);
    return u;
  }
  // i16 coordinates in units of `scale` mm, -32768 for NaN
  function coords(s, scale) {
    var q = new Int16Array(bytes(s).buffer), f = new Float32Array(q.length);
    for (var i = 0; i < q.length; i++) f[i] = q[i] === -32768 ? NaN : q[i] * scale;
    return f;
  }
  function apply(m, v) {
    var r = [];
    for (var a = 0; a < 3; a++) r.push(m[4 * a] * v[0] + m[4 * a + 1] * v[1] + m[4 * a + 2] * v[2] + m[4 * a + 3]);
    return r;
  }
  function fmt(p) { return p.map(function (x) { return x.toFixed(2); }).join(","); }
  // Bilinear over the four pixels around (u, v) when all are inside, else the nearest.
  function lookup(get, u, v) {
    var i0 = Math.floor(u), j0 = Math.floor(v), acc = [0, 0, 0];
    for (var c = 0; c < 4; c++) {
      var di = c & 1, dj = c >> 1, p = get(i0 + di, j0 + dj);
      if (!p) return get(Math.round(u), Math.round(v));
      var w = (di ? u - i0 : 1 - u + i0) * (dj ? v - j0 : 1 - v + j0);
      for (var a = 0; a < 3; a++) acc[a] += w * p[a];
    }
    return acc;
  }
  function view(nx, ny, title) {
    var z = Math.max(1, Math.floor(360 / Math.max(nx, ny)));
    var fig = document.createElement("figure"), cap = document.createElement("figcaption");
    var c = document.createElement("canvas");
    c.width = nx * z; c.height = ny * z;
    cap.textContent = title;
    fig.appendChild(c); fig.appendChild(cap);
    var off = document.createElement("canvas");
    off.width = nx; off.height = ny;
    return {
      fig: fig, canvas: c, cap: cap, zoom: z,
      // the voxel coordinates (u, v) of a click
      at: function (e) {
        var s = c.width / c.clientWidth;
        return [e.offsetX * s / z - 0.5, e.offsetY * s / z - 0.5];
      },
      draw: function (values, offset, marker) {
        var img = off.getContext("2d").createImageData(nx, ny);
        for (var p = 0; p < nx * ny; p++) {
          var g = values[offset + p];
          img.data[4 * p] = img.data[4 * p + 1] = img.data[4 * p + 2] = g;
          img.data[4 * p + 3] = 255;
        }
        off.getContext("2d").putImageData(img, 0, 0);
        var ctx = c.getContext("2d");
        ctx.imageSmoothingEnabled = false;
        ctx.drawImage(off, 0, 0, c.width, c.height);
        if (marker) {
          var x = (marker[0] + 0.5) * z, y = (marker[1] + 0.5) * z;
          ctx.strokeStyle = "#e00"; ctx.lineWidth = 2;
          ctx.beginPath(); ctx.arc(x, y, 6, 0, 2 * Math.PI);
          ctx.moveTo(x - 10, y); ctx.lineTo(x + 10, y); ctx.moveTo(x, y - 10); ctx.lineTo(x, y + 10);
          ctx.stroke();
          c.setAttribute("data-marker-px", x.toFixed(2) + "," + y.toFixed(2));
        } else {
          c.removeAttribute("data-marker-px");
        }
      }
    };
  }
  function setup(root) {
    var d = JSON.parse(root.querySelector("script.lv-data").textContent);
    var F = d.flat, S = d.scan;
    var fx = F.dims[0], fy = F.dims[1], sx = S.dims[0], sy = S.dims[1], sz = S.dims[2];
    var fval = bytes(F.values), fmap = coords(F.scanner, F.scanner_scale);
    var sval = bytes(S.values), inside = bytes(S.inside), smap = coords(S.template, S.template_scale);
    var rank = new Int32Array(inside.length), n = 0;
    for (var i = 0; i < inside.length; i++) rank[i] = inside[i] ? n++ : -1;
    var flat = view(fx, fy, "flat " + d.image + " (template slice k = " + F.k + ")");
    var scan = view(sx, sy, "scan");
    var out = document.createElement("p");
    out.className = "lv-readout";
    out.textContent = "Click a point of either image.";
    root.appendChild(flat.fig); root.appendChild(scan.fig); root.appendChild(out);
    var k = Math.floor(sz / 2);
    function showScan(marker) {
      scan.draw(sval, sx * sy * k, marker);
      scan.cap.textContent = "scan (scanner space), slice k = " + k + " of " + sz;
    }
    function flatGet(i, j) {
      if (i < 0 || j < 0 || i >= fx || j >= fy) return null;
      var p = 3 * (i + fx * j);
      return isNaN(fmap[p]) ? null : [fmap[p], fmap[p + 1], fmap[p + 2]];
    }
    function scanGet(i, j) {
      if (i < 0 || j < 0 || i >= sx || j >= sy) return null;
      var r = rank[i + sx * (j + sy * k)];
      return r < 0 ? null : [smap[3 * r], smap[3 * r + 1], smap[3 * r + 2]];
    }
    function report(t, x, text) {
      out.setAttribute("data-template-mm", t ? fmt(t) : "");
      out.setAttribute("data-scanner-mm", x ? fmt(x) : "");
      out.setAttribute("data-state", text ? "outside" : "inside");
      out.textContent = text || ("template " + fmt(t) + " mm \u2194 scanner " + fmt(x) + " mm");
    }
    flat.canvas.addEventListener("click", function (e) {
      var uv = flat.at(e), t = apply(F.affine, [uv[0], uv[1], F.k]);
      var x = lookup(flatGet, uv[0], uv[1]);
      flat.draw(fval, 0, uv);
      if (!x) { showScan(null); report(t, null, "template " + fmt(t) + " mm: outside the placenta"); return; }
      var v = apply(S.inverse, x);
      k = Math.min(sz - 1, Math.max(0, Math.round(v[2])));
      showScan([v[0], v[1]]);
      report(t, x, null);
    });
    scan.canvas.addEventListener("click", function (e) {
      var uv = scan.at(e), x = apply(S.affine, [uv[0], uv[1], k]);
      var t = lookup(scanGet, uv[0], uv[1]);
      showScan(uv);
      if (!t) { flat.draw(fval, 0, null); report(null, x, "scanner " + fmt(x) + " mm: outside the placenta"); return; }
      var v = apply(F.inverse, t);
      flat.draw(fval, 0, [v[0], v[1]]);
      report(t, x, null);
    });
    flat.draw(fval, 0, null);
    showScan(null);
  }
  // A ventricle: a click on the disk marks the surface point on the rendering.
  function setupVentricle(root) {
    var d = JSON.parse(root.querySelector("script.lv-data").textContent);
    var D = d.disk, R = d.render, n = D.n;
    var dval = bytes(D.values), surf = coords(D.surface, D.surface_scale);
    var rpx = coords(D.render_px, D.render_px_scale), rval = bytes(R.values);
    var disk = view(n, n, "disk (AHA segments)");
    var ren = view(R.w, R.h, "surface (scanner space), seen from the side");
    var out = document.createElement("p");
    out.className = "lv-readout";
    out.textContent = "Click a point of the disk.";
    root.appendChild(disk.fig); root.appendChild(ren.fig); root.appendChild(out);
    disk.canvas.addEventListener("click", function (e) {
      var uv = disk.at(e), i = Math.round(uv[0]), j = Math.round(uv[1]), p = i + n * j;
      var xz = [-1 + (uv[0] + 0.5) * 2 / n, 1 - (uv[1] + 0.5) * 2 / n];
      disk.draw(dval, 0, uv);
      out.setAttribute("data-disk", fmt(xz));
      if (i < 0 || j < 0 || i >= n || j >= n || isNaN(surf[3 * p])) {
        ren.draw(rval, 0, null);
        out.setAttribute("data-scanner-mm", ""); out.setAttribute("data-state", "outside");
        out.textContent = "disk " + fmt(xz) + ": outside the disk";
        return;
      }
      var x = [surf[3 * p], surf[3 * p + 1], surf[3 * p + 2]];
      out.setAttribute("data-scanner-mm", fmt(x));
      if (isNaN(rpx[2 * p])) {
        ren.draw(rval, 0, null);
        out.setAttribute("data-state", "far");
        out.textContent = "disk " + fmt(xz) + " \u2194 scanner " + fmt(x) + " mm: on the far side of this view";
        return;
      }
      ren.draw(rval, 0, [rpx[2 * p] - 0.5, rpx[2 * p + 1] - 0.5]);
      out.setAttribute("data-state", "inside");
      out.textContent = "disk " + fmt(xz) + " \u2194 scanner " + fmt(x) + " mm";
    });
    disk.draw(dval, 0, null);
    ren.draw(rval, 0, null);
  }
  var roots = document.querySelectorAll("div.lv");
  for (var r = 0; r < roots.length; r++) setup(roots[r]);
  roots = document.querySelectorAll("div.lvv");
  for (r = 0; r < roots.length; r++) setupVentricle(roots[r]);
})();
