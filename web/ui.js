// Controls (B, C, G, Vm and glare never restart rendering; integrator and mode do) and the
// overlay.

import { ENUMS } from './protocol.js';

// Fills a menu with an enumeration of the protocol (values the wire names, labels for people),
// so a mode or integrator added on the server appears here without editing the page.
function fill(select, e) {
  for (const v of ENUMS[e].values) select.add(new Option(v.label, v.name));
}

export function controls(onDisplay, onParams, onNavigation, onPlay) {
  const params = { B: 1.5, C: 1.0, G: 2.2, Vm: 0.0, glare: 0.0 };
  const bind = (id, key, fmt) => {
    const el = document.getElementById(id);
    const out = document.getElementById(`${id}-value`);
    const update = () => {
      params[key] = fmt(Number(el.value));
      out.textContent = params[key].toFixed(2);
      onDisplay(params);
    };
    el.addEventListener('input', update);
    params[key] = fmt(Number(el.value));
    out.textContent = params[key].toFixed(2);
  };
  // Brightness on a log scale: the slider is log2 B.
  bind('brightness', 'B', (v) => 2 ** v);
  bind('contrast', 'C', (v) => v);
  bind('gamma', 'G', (v) => v);
  bind('vm', 'Vm', (v) => v);
  bind('glare', 'glare', (v) => v);
  const integrator = document.getElementById('integrator');
  const mode = document.getElementById('mode');
  fill(integrator, 'integrator');
  fill(mode, 'mode');
  const send = () => onParams(integrator.value, mode.value);
  integrator.addEventListener('change', send);
  mode.addEventListener('change', send);
  const nav = document.getElementById('navigation');
  nav.addEventListener('change', () => onNavigation(nav.value));
  // Shown once the server says the scene is animated (ANIMATE); the label names the action.
  const play = document.getElementById('play');
  let playing = false;
  play.addEventListener('click', () => onPlay(!playing));
  return {
    params,
    setParams(i, m) { integrator.value = i; mode.value = m; },
    setAnimation(p) { playing = p; play.hidden = false; play.textContent = p ? 'pause' : 'play'; },
  };
}

export function overlay(el, s) {
  const si = (v) => (v >= 1e6 ? `${(v / 1e6).toFixed(2)} M` : v >= 1e3 ? `${(v / 1e3).toFixed(1)} k` : `${v.toFixed(0)} `);
  el.textContent = [
    `${s.name}  ${s.width}×${s.height}  ${s.integrator} / ${s.mode}`,
    `samples/s ${si(s.rate)}  spp ${s.spp.toFixed(3)}  fps ${s.fps.toFixed(0)}  LoD ${s.lod.toFixed(2)}`,
    `samples ${si(s.samples)}  light paths ${si(s.lightPaths)}  dropped ${s.dropped}  viewers ${s.viewers}`,
  ].join('\n');
}
