"""The orbit table of the explore page (HTML), apart from the page's plots."""
from __future__ import annotations

import html

import numpy as np

from hertzmap.study.explore_data import ORBIT_TABLE_FIELDS


def _fmt(x, digits: int = 7) -> str:
    try:
        x = float(x)
    except (TypeError, ValueError):
        return html.escape(str(x))
    return "-" if not np.isfinite(x) else f"{x:.{digits}g}"


def _complex(z: complex) -> str:
    if not np.isfinite(z.real):
        return "-"
    sign = "+" if z.imag >= 0 else "-"
    return f"{z.real:.5g} {sign} {abs(z.imag):.5g}i"


def orbit_table(rows, u) -> str:
    """The orbits of a point as an HTML table, one column per orbit (``rows``: (k, orbits,
    history, closure, class code, colour, class label) per orbit of
    ``explore_data.point_orbits``), in the page's units ``u``: a row for each field of
    ``explore_data.ORBIT_TABLE_FIELDS`` the store holds, named by its long_name. Each number
    cell carries ``data-orbit`` and ``data-field`` (the browser test reads them)."""
    if not rows:
        return "<p class='muted'>no converged periodic orbit stored at this point</p>"
    du = "" if not u.physical else u.disp.unit
    vu = "" if not u.physical else u.vel.unit
    fu = "" if not u.physical else u.force.unit

    def line(label, unit, field, values, fmt=_fmt):
        tds = "".join(f"<td data-orbit='{k}' data-field='{field}'>{fmt(val)}</td>"
                      for k, val in values)
        return f"<tr><td class='q'>{label}</td><td class='u'>{unit}</td>{tds}</tr>"

    head = "".join(
        f"<th><span class='swatch' style='background:{color}'></span>#{int(orb['slot'].values[k])}</th>"
        for k, orb, h, closure, c, color, clabel in rows)
    get = lambda name: [(k, orb[name].values[k]) for k, orb, *_ in rows]  # noqa: E731
    sim_min = [(k, u.disp(np.min(h["q"]))) for k, orb, h, *_ in rows]
    mults = [(k, orb["multipliers"].values[k]) for k, orb, *_ in rows]
    body = [
        line("class", "", "class", [(k, cl) for k, _, _, _, _, _, cl in rows],
             fmt=html.escape),
        line("period", "T", "period", get("period"), fmt=lambda p: f"{int(p)}"),
        line("stable", "", "stable", get("stable"), fmt=lambda b: "yes" if b else "no"),
    ]
    if "basin_fraction" in rows[0][1]:
        body.append(line("basin share (census)", "%", "basin_fraction",
                         [(k, 100 * x) for k, x in get("basin_fraction")],
                         fmt=lambda x: _fmt(x, 3)))
    body += [
        line("largest |multiplier|", "", "max_abs_mu",
             [(k, np.max(np.abs(m))) for k, m in mults]),
        line("multiplier 1", "", "mu1", [(k, m[0]) for k, m in mults], fmt=_complex),
        line("multiplier 2", "", "mu2", [(k, m[1]) for k, m in mults], fmt=_complex),
    ]
    scale = {"displacement": (u.disp, du), "velocity": (u.vel, vu), "force": (u.force, fu),
             "fraction": (lambda x: 100 * x, "%"), None: (lambda x: x, "")}
    orbits = rows[0][1]
    for f in ORBIT_TABLE_FIELDS:
        if f.name in ("period", "stable") or f.name not in orbits:
            continue
        conv, unit = scale[f.quantity]
        fmt = (lambda b: "yes" if b else "no") if f.dtype == "bool" else _fmt
        body.append(line(f.long_name, unit, f.name,
                         [(k, x if f.dtype == "bool" else conv(x)) for k, x in get(f.name)],
                         fmt=fmt))
        if f.name == "min_q":
            body.append(line("minimum displacement (simulated)", du, "min_q_sim", sim_min))
    if "min_q" not in orbits:
        body.append(line("minimum displacement (simulated)", du, "min_q_sim", sim_min))
    body += [
        line("closure |x(P) - x(0)|", "", "closure",
             [(k, closure) for k, _, _, closure, *_ in rows], fmt=lambda x: f"{x:.1e}"),
    ]
    return ("<table class='orbits' id='orbit_table'><tr><th class='q'>orbit</th><th></th>"
            + head + "</tr>" + "".join(body) + "</table>")
