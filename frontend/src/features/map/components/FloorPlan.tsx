import type { Box, Floor } from '../api/map';

export type Project = (x: number, y: number) => readonly [number, number];
type Available = Extract<Floor, { available: true }>;

/** The robot's map under everything else: the floor colour, the unmapped area and the walls,
 *  each a theme colour shown through the map's PNG mask, and what the robot saw blocked. */
export function FloorPlan({ floor, project }: { floor: Available; project: Project }) {
  const { origin, resolution, width, height } = floor;
  const [x, y] = project(origin.x, origin.y + height * resolution);
  const [x1, y1] = project(origin.x + width * resolution, origin.y);
  const area = { x, y, width: x1 - x, height: y1 - y };
  const id = `floor-${floor.version}`;
  return (
    <g data-testid="floor-plan" aria-hidden="true">
      <defs>
        <mask id={`${id}-unknown`} maskUnits="userSpaceOnUse" {...area}>
          <image href={`data:image/png;base64,${floor.unknown_png}`} {...area} preserveAspectRatio="none" style={{ imageRendering: 'pixelated' }} />
        </mask>
        <mask id={`${id}-walls`} maskUnits="userSpaceOnUse" {...area}>
          <image href={`data:image/png;base64,${floor.walls_png}`} {...area} preserveAspectRatio="none" style={{ imageRendering: 'pixelated' }} />
        </mask>
      </defs>
      <rect {...area} className="fill-map-unknown" mask={`url(#${id}-unknown)`} />
      <rect {...area} className="fill-map-wall" mask={`url(#${id}-walls)`} />
    </g>
  );
}

/** A way the robot's costmap blocks where the map is free: drawn over the gap in the wall. */
export function Blocked({ box, project }: { box: Box; project: Project }) {
  const [x0, y0] = project(box.x0, box.y1);
  const [x1, y1] = project(box.x1, box.y0);
  const pad = 1.5; // a door is a few pixels thin at this scale: keep it visible
  return (
    <g data-testid="blocked" role="img" aria-label="Blocked: the robot saw this way closed">
      <title>The robot saw this way blocked (a closed door or an obstacle)</title>
      <rect x={x0 - pad} y={y0 - pad} width={x1 - x0 + 2 * pad} height={y1 - y0 + 2 * pad} rx={1} className="fill-map-blocked" />
    </g>
  );
}

/** The path the robot follows now, from where it is to its destination. */
export function PlanLine({ points, project }: { points: [number, number][]; project: Project }) {
  const last = points[points.length - 1];
  if (points.length < 2 || !last) return null;
  const d = points.map(([px, py], i) => {
    const [sx, sy] = project(px, py);
    return `${i === 0 ? 'M' : 'L'} ${sx.toFixed(1)} ${sy.toFixed(1)}`;
  });
  const [ex, ey] = project(last[0], last[1]);
  return (
    <g data-testid="plan" data-points={points.length} aria-hidden="true">
      <path d={d.join(' ')} className="fill-none stroke-map-plan" strokeWidth={2} strokeDasharray="5 3" strokeLinecap="round" strokeLinejoin="round" />
      <circle cx={ex} cy={ey} r={3} className="fill-map-plan" />
    </g>
  );
}
