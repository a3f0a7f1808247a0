import { describe, expect, it } from 'vitest';
import { arrowPoints, boxOf, markerObstacles, overlaps, placeLabels, type Box, type LabelSpot } from './labelPlacement';

const RING = 14; // the map's history ring radius
const HISTORY = 'yellow package · 23:54:33';

/** The box a placed name covers (10 px text: 10 above the baseline, 2 below). */
function textBox([x, y, anchor]: LabelSpot, name: string, charWidth = 5.6): Box {
  const w = name.length * charWidth;
  const x0 = anchor === 'start' ? x : anchor === 'end' ? x - w : x - w / 2;
  return { x0, x1: x0 + w, y0: y - 10, y1: y + 2 };
}

describe('arrowPoints', () => {
  it('points the way the robot faced: east is right, north is up on screen', () => {
    const [, east] = arrowPoints(100, 50, 0, RING);
    expect(east[0]).toBeCloseTo(100 + RING + 5);
    expect(east[1]).toBeCloseTo(50);
    const [, north] = arrowPoints(100, 50, Math.PI / 2, RING);
    expect(north[0]).toBeCloseTo(100);
    expect(north[1]).toBeCloseTo(50 - RING - 5);
    const [, southWest] = arrowPoints(100, 50, (-3 * Math.PI) / 4, RING);
    expect(southWest[0]).toBeLessThan(100);
    expect(southWest[1]).toBeGreaterThan(50);
  });
});

describe('placeLabels', () => {
  it('puts a history label beside a place, never over its name, and inside the map', () => {
    const placed = placeLabels([
      { name: 'mailroom', cx: 266, cy: 130 },
      { name: 'reception', cx: 89, cy: 150 },
      { name: HISTORY, cx: 266, cy: 130, r: 17, charWidth: 6.2 },
    ]);
    const label = textBox(placed.get(HISTORY)!, HISTORY, 6.2);
    expect(label.x0).toBeGreaterThanOrEqual(2);
    expect(label.x1).toBeLessThanOrEqual(298);
    for (const name of ['mailroom', 'reception']) {
      expect(overlaps(label, textBox(placed.get(name)!, name))).toBe(false);
    }
  });

  it('keeps a name above its dot when nothing is in the way', () => {
    const placed = placeLabels([{ name: 'kitchen', cx: 150, cy: 80 }]);
    expect(placed.get('kitchen')).toEqual([150, 68, 'middle']);
  });

  it('the old placement put the place name on a northward arrow (the bug this fixes)', () => {
    const arrow = boxOf(arrowPoints(266, 130, Math.PI / 2, RING));
    const ignoring = placeLabels([{ name: 'mailroom', cx: 266, cy: 130 }]);
    expect(overlaps(textBox(ignoring.get('mailroom')!, 'mailroom'), arrow)).toBe(true);
    const avoiding = placeLabels([{ name: 'mailroom', cx: 266, cy: 130 }], 300, markerObstacles(266, 130, Math.PI / 2, RING));
    expect(overlaps(textBox(avoiding.get('mailroom')!, 'mailroom'), arrow)).toBe(false);
  });

  // The robot stood at or near the mailroom facing every way: the arrow, the ring, the place
  // names and the history label never cover one another, and every name stays on the map.
  const headings = Array.from({ length: 16 }, (_, i) => (i * Math.PI) / 8);
  const offsets: [number, number][] = [
    [0, 0],
    [7, -5],
    [-9, 6],
    [4, 10],
  ];
  for (const [ox, oy] of offsets) {
    it(`keeps names clear of the marker at offset ${ox},${oy} for every heading`, () => {
      for (const yaw of headings) {
        const [mx, my] = [200 + ox, 120 + oy];
        const places = [
          { name: 'mailroom', cx: 200, cy: 120 },
          { name: 'reception', cx: 120, cy: 150 },
          { name: 'kitchen', cx: 230, cy: 60 },
        ];
        const placed = placeLabels(
          [...places, { name: HISTORY, cx: mx, cy: my, r: RING + 3, charWidth: 6.2 }],
          300,
          markerObstacles(mx, my, yaw, RING),
          240,
        );
        const arrow = boxOf(arrowPoints(mx, my, yaw, RING), 3); // and a visible gap
        const ring: Box = { x0: mx - RING, y0: my - RING, x1: mx + RING, y1: my + RING };
        const names = places.map((p) => textBox(placed.get(p.name)!, p.name));
        const history = textBox(placed.get(HISTORY)!, HISTORY, 6.2);
        const where = `yaw ${yaw.toFixed(2)}`;
        for (const box of [...names, history]) {
          expect(overlaps(box, arrow), where).toBe(false);
          expect(box.x0, where).toBeGreaterThanOrEqual(2);
          expect(box.x1, where).toBeLessThanOrEqual(298);
          expect(box.y0, where).toBeGreaterThanOrEqual(0);
        }
        for (const box of names) {
          expect(overlaps(box, ring), where).toBe(false);
          expect(overlaps(box, history), where).toBe(false);
        }
        for (const p of places) {
          // a name moved out of the marker's way stays near its dot
          const box = textBox(placed.get(p.name)!, p.name);
          const gap = Math.max(box.x0 - p.cx, p.cx - box.x1, box.y0 - p.cy, p.cy - box.y1, 0);
          expect(gap, `${p.name} ${where}`).toBeLessThanOrEqual(7 + 3 + 28 + 1);
        }
      }
    });
  }
});
