/** Where the floor map's names go (pure geometry in SVG pixels, y pointing down): each name
 *  beside its dot, clear of the other names, the dots and the history marker's ring and
 *  heading arrow, inside the map. */

export type Box = { x0: number; y0: number; x1: number; y1: number };
export type Anchor = 'middle' | 'start' | 'end';
/** A name's baseline position and text anchor. */
export type LabelSpot = [number, number, Anchor];
/** A named dot: `r` is the dot's radius (7 by default), `charWidth` the name's pixels per letter. */
export type LabelPoint = { name: string; cx: number; cy: number; r?: number; charWidth?: number };
type Point = readonly [number, number];

export const MAP_WIDTH = 300;
const EDGE = 2; // px kept free at the map's left and right edges
const MAX_PUSH = 28; // px a name may move away from its dot to clear what lies beside it

export const overlaps = (a: Box, b: Box) => a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;

/** The box around `points`, grown by `pad`. */
export function boxOf(points: readonly Point[], pad = 0): Box {
  const xs = points.map(([x]) => x);
  const ys = points.map(([, y]) => y);
  return { x0: Math.min(...xs) - pad, y0: Math.min(...ys) - pad, x1: Math.max(...xs) + pad, y1: Math.max(...ys) + pad };
}

/** The heading arrow of a marker whose ring has radius `ring`, at (cx, cy) on screen, facing
 *  `yaw` (map radians, counter-clockwise from +x; the screen's y points down): a triangle from
 *  just inside the ring to 5 px beyond it. The map draws these points and places names
 *  around them, so what is drawn is what is avoided. */
export function arrowPoints(cx: number, cy: number, yaw: number, ring: number): [Point, Point, Point] {
  const [c, s] = [Math.cos(yaw), Math.sin(yaw)];
  const at = (along: number, across: number): Point => [cx + along * c + across * s, cy - along * s + across * c];
  return [at(ring - 1, -4), at(ring + 5, 0), at(ring - 1, 4)];
}

// Clear space kept around the marker: a name's descenders and its 1.5 px halo reach below the
// box a name is given, and an arrow tip that touches a name reads as part of it.
const MARKER_GAP = 3.5;

/** A history marker's footprint for the names to avoid: its ring and its heading arrow. */
export function markerObstacles(cx: number, cy: number, yaw: number, ring: number): Box[] {
  return [
    { x0: cx - ring - 2, y0: cy - ring - 2, x1: cx + ring + 2, y1: cy + ring + 2 },
    boxOf(arrowPoints(cx, cy, yaw, ring), MARKER_GAP),
  ];
}

type Side = { anchor: Anchor; dx: number; dy: number };
// Above, below, right, left: the order names are tried in when all fit equally well.
const ABOVE: Side = { anchor: 'middle', dx: 0, dy: -1 };
const SIDES: Side[] = [
  ABOVE,
  { anchor: 'middle', dx: 0, dy: 1 },
  { anchor: 'start', dx: 1, dy: 0 },
  { anchor: 'end', dx: -1, dy: 0 },
];

type Candidate = { spot: LabelSpot; box: Box; push: number; side: number };

/** A name's spot on one side of its dot; a centred name that would leave the map slides back in. */
function besideDot(p: LabelPoint, side: Side, w: number, width: number): Candidate {
  const r = p.r ?? 7;
  let spot: LabelSpot;
  let box: Box;
  if (side.dy < 0) {
    spot = [p.cx, p.cy - r - 5, 'middle'];
    box = { x0: p.cx - w / 2, y0: p.cy - r - 15, x1: p.cx + w / 2, y1: p.cy - r - 3 };
  } else if (side.dy > 0) {
    spot = [p.cx, p.cy + r + 13, 'middle'];
    box = { x0: p.cx - w / 2, y0: p.cy + r + 3, x1: p.cx + w / 2, y1: p.cy + r + 15 };
  } else if (side.dx > 0) {
    spot = [p.cx + r + 3, p.cy + 4, 'start'];
    box = { x0: p.cx + r + 3, y0: p.cy - 6, x1: p.cx + r + 3 + w, y1: p.cy + 6 };
  } else {
    spot = [p.cx - r - 3, p.cy + 4, 'end'];
    box = { x0: p.cx - r - 3 - w, y0: p.cy - 6, x1: p.cx - r - 3, y1: p.cy + 6 };
  }
  if (side.anchor === 'middle') {
    const shift = box.x0 < EDGE ? EDGE - box.x0 : box.x1 > width - EDGE ? width - EDGE - box.x1 : 0;
    spot = [spot[0] + shift, spot[1], spot[2]];
    box = { ...box, x0: box.x0 + shift, x1: box.x1 + shift };
  }
  return { spot, box, push: 0, side: SIDES.indexOf(side) };
}

/** The candidate moved further out along its side until it clears everything in `taken`, or
 *  null when that is more than MAX_PUSH away. */
function pushedClear(c: Candidate, side: Side, taken: Box[]): Candidate | null {
  let { box, push } = c;
  for (let round = 0; round < 8; round += 1) {
    const blocking = taken.filter((b) => overlaps(b, box));
    if (blocking.length === 0) {
      const [x, y, anchor] = c.spot;
      return { ...c, box, push, spot: [x + side.dx * push, y + side.dy * push, anchor] };
    }
    const step = Math.max(
      ...blocking.map((b) =>
        side.dy < 0 ? box.y1 - b.y0 : side.dy > 0 ? b.y1 - box.y0 : side.dx > 0 ? b.x1 - box.x0 : box.x1 - b.x0,
      ),
    );
    push += step + 0.5;
    if (push > MAX_PUSH) return null;
    const [mx, my] = [side.dx * (step + 0.5), side.dy * (step + 0.5)];
    box = { x0: box.x0 + mx, y0: box.y0 + my, x1: box.x1 + mx, y1: box.y1 + my };
  }
  return null;
}

/** Name positions (label baselines) in the order given: each avoids the dots, the names placed
 *  before it and `obstacles` (e.g. the history marker), on the first side (above, below,
 *  right, left) where it fits inside the map; where no side fits as is, the side that needs
 *  the least move away from the dot (at most MAX_PUSH px). */
export function placeLabels(
  points: LabelPoint[],
  width = MAP_WIDTH,
  obstacles: Box[] = [],
  height = Number.POSITIVE_INFINITY,
): Map<string, LabelSpot> {
  const taken: Box[] = [
    ...obstacles,
    ...points.map((p) => {
      const r = p.r ?? 7;
      return { x0: p.cx - r, y0: p.cy - r, x1: p.cx + r, y1: p.cy + r };
    }),
  ];
  const inside = (box: Box) => box.x0 >= EDGE && box.x1 <= width - EDGE && box.y0 >= 0 && box.y1 <= height;
  const result = new Map<string, LabelSpot>();
  for (const p of points) {
    const w = p.name.length * (p.charWidth ?? 5.6);
    const fits = SIDES.map((side) => pushedClear(besideDot(p, side, w, width), side, taken)).filter(
      (c): c is Candidate => c !== null,
    );
    fits.sort((a, b) => Number(!inside(a.box)) - Number(!inside(b.box)) || a.push - b.push || a.side - b.side);
    const best = fits[0] ?? besideDot(p, ABOVE, w, width); // nowhere free: above, as before
    taken.push(best.box);
    result.set(p.name, best.spot);
  }
  return result;
}
