import { useCallback, useMemo, useState, type ReactNode } from 'react';
import { Panel } from '@/components/ui/Panel';
import { usePolling } from '@/lib/usePolling';
import { localClock, type RobotPose, type Sighting } from '@/features/history/api/history';
import { Button } from '@/components/ui/Button';
import { useChatStore } from '@/stores/chatStore';
import { useHistoryStore } from '@/stores/historyStore';
import { fetchFloor, fetchLocations, fetchPlan, fetchPose, type Floor, type LocationList, type Plan, type Pose } from '../api/map';
import { Blocked, FloorPlan, PlanLine } from './FloorPlan';
import {
  arrowPoints,
  MAP_WIDTH,
  markerObstacles,
  placeLabels,
  type Anchor,
  type LabelPoint,
  type LabelSpot,
} from '../labelPlacement';

const POSE_PERIOD_MS = 400; // 2.5 Hz
const PLAN_PERIOD_MS = 1000; // Nav2 replans once a second
const FLOOR_PERIOD_MS = 3000; // the map changes rarely; the costmap when a door is seen
const WIDTH = MAP_WIDTH;
const PAD = 34;
const FLOOR_PAD = 10; // a floor plan fills the panel; markers at its edge stay whole

type Point = { x: number; y: number };

/** Map metres → SVG pixels (y up in the map, down on screen); the height follows the map. With
 *  a floor plan the view is the mapped area, else the places. */
function projection(list: LocationList, points: Point[], floor: Floor | null) {
  const bounds = floor?.available ? floor.bounds : null;
  const corners = bounds ? [{ x: bounds.x0, y: bounds.y0 }, { x: bounds.x1, y: bounds.y1 }] : [];
  const pad = bounds ? FLOOR_PAD : PAD;
  const xs = list.locations.map((l) => l.x).concat([...points, ...corners].map((p) => p.x));
  const ys = list.locations.map((l) => l.y).concat([...points, ...corners].map((p) => p.y));
  const [minX, maxX, minY, maxY] = [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
  const scale = (WIDTH - 2 * pad) / Math.max(maxX - minX, 1);
  const height = Math.max(140, 2 * pad + (maxY - minY) * scale);
  const project = (x: number, y: number) => [pad + (x - minX) * scale, height - pad - (y - minY) * scale] as const;
  return { project, height };
}

const HISTORY_KEY = '\u0000history'; // never a location's name

/** A place as people name it; never its map id (navigation's label, else the id in words). */
function placeName(loc: { name: string; label?: string }): string {
  return loc.label ?? loc.name.replace(/_/g, ' ');
}

function placeNamed(list: LocationList | null, name: string): string {
  const loc = list?.locations.find((l) => l.name === name);
  return loc ? placeName(loc) : name.replace(/_/g, ' ');
}
const HISTORY_RING = 14;

export function MapView() {
  const [list, setList] = useState<LocationList | null>(null);
  const [pose, setPose] = useState<Pose | null>(null);
  const [floor, setFloor] = useState<Floor | null>(null);
  const [plan, setPlan] = useState<Plan | null>(null);
  const [error, setError] = useState<string | null>(null);
  const setDraft = useChatStore((s) => s.setDraft);
  const past = useHistoryStore((s) => s.selected);
  const clearPast = useHistoryStore((s) => s.select);

  const tick = useCallback(async () => {
    try {
      const current = list ?? (await fetchLocations());
      if (!list) setList(current);
      setPose(await fetchPose());
      setError(null);
    } catch (err) {
      setError(err instanceof Error ? err.message : String(err));
    }
  }, [list]);
  usePolling(tick, list ? POSE_PERIOD_MS : 3000);
  const tickFloor = useCallback(async () => {
    try {
      const next = await fetchFloor();
      setFloor((old) => (old?.available && next.available && old.version === next.version ? old : next));
    } catch {
      setFloor(null); // navigation down: the places alone
    }
  }, []);
  usePolling(tickFloor, FLOOR_PERIOD_MS, list !== null);
  const moving = pose?.moving ?? false;
  const tickPlan = useCallback(async () => {
    try {
      setPlan(await fetchPlan());
    } catch {
      setPlan(null);
    }
  }, []);
  usePolling(tickPlan, PLAN_PERIOD_MS, moving);
  const planPoints = moving && plan ? plan.points : [];

  // A sighting recorded on another map has no place on this one: it is named, not drawn.
  const pastPose = past?.pose && list && (past.pose.map === null || past.pose.map === list.map) ? past.pose : null;
  const view = useMemo(
    () => (list ? projection(list, [...(pose ? [pose] : []), ...(pastPose ? [pastPose] : [])], floor) : null),
    [list, pose, pastPose, floor],
  );
  const project = view?.project ?? null;
  const pastText = past && pastPose ? `${past.label} · ${localClock(past.first_seen)}` : null;
  const labels = useMemo(() => {
    if (!list || !view) return new Map<string, LabelSpot>();
    const points: LabelPoint[] = list.locations.map((l) => {
      const [cx, cy] = view.project(l.x, l.y);
      return { name: placeName(l), cx, cy };
    });
    // The history marker's ring and heading arrow are kept clear of every name.
    const obstacles = pastPose ? markerObstacles(...view.project(pastPose.x, pastPose.y), pastPose.yaw, HISTORY_RING) : [];
    if (pastPose && pastText) {
      // Placed last: the history label moves around the places' names, never over them.
      const [cx, cy] = view.project(pastPose.x, pastPose.y);
      points.push({ name: pastText, cx, cy, r: HISTORY_RING + 3, charWidth: 6.2 });
    }
    const placed = placeLabels(points, WIDTH, obstacles, view.height);
    const history = pastText ? placed.get(pastText) : undefined;
    if (history) placed.set(HISTORY_KEY, history);
    return placed;
  }, [list, view, pastPose, pastText]);
  const destination = pose?.destination ?? null;
  // On a floor plan the markers are smaller: corridors are a dozen pixels wide.
  const markerScale = floor?.available ? 0.7 : 1;
  const destinationName = list?.locations.find((l) => l.name === destination);

  return (
    <Panel label="Map" title={list ? `Map — ${list.map}` : 'Map'}>
      {!list || !project ? (
        <p className="p-3 text-sm text-muted">{error ? `Navigation unavailable: ${error}` : 'Loading the map…'}</p>
      ) : (
        <svg viewBox={`0 0 ${WIDTH} ${view?.height ?? WIDTH}`} className="block w-full bg-map-floor lg:max-h-[38vh]" role="group" aria-label="Floor map">
          {floor?.available && <FloorPlan floor={floor} project={project} />}
          {floor?.available && floor.blocked.map((box) => <Blocked key={`${box.x0},${box.y0}`} box={box} project={project} />)}
          <PlanLine points={planPoints} project={project} />
          {/* Under the places' names (haloed, placed clear of its ring and arrow) and under the
              live robot, so both stay readable where they coincide. */}
          {past && pastPose && (
            <HistoryMarker
              sighting={past}
              pose={pastPose}
              at={project(pastPose.x, pastPose.y)}
              label={labels.get(HISTORY_KEY) ?? [project(pastPose.x, pastPose.y)[0], project(pastPose.x, pastPose.y)[1] - 22, 'middle']}
            />
          )}
          {list.locations.map((loc) => {
            const [cx, cy] = project(loc.x, loc.y);
            const name = placeName(loc);
            const [lx, ly, anchor] = labels.get(name) ?? [cx, cy - 12, 'middle'];
            const isDestination = loc.name === destination;
            return (
              <g
                key={loc.name}
                role="button"
                tabIndex={0}
                aria-label={`Go to ${name}`}
                data-destination={isDestination || undefined}
                className="cursor-pointer focus-visible:outline-2 focus-visible:outline-accent"
                onClick={() => setDraft(`Go to ${name}`)}
                onKeyDown={(e) => {
                  if (e.key === 'Enter' || e.key === ' ') {
                    e.preventDefault();
                    setDraft(`Go to ${name}`);
                  }
                }}
              >
                <title>{loc.description || name}</title>
                {/* A generous, invisible tap target covering the dot and its name. */}
                <rect x={cx - 34} y={cy - 26} width={68} height={38} fill="transparent" />
                <circle
                  cx={cx}
                  cy={cy}
                  r={(isDestination ? 9 : 6) * markerScale}
                  className={isDestination ? 'fill-surface stroke-accent' : 'fill-surface stroke-muted'}
                  strokeWidth={isDestination ? 3 : 2}
                />
                <MapLabel x={lx} y={ly} anchor={anchor} className="fill-fg">
                  {name}
                </MapLabel>
              </g>
            );
          })}
          {pose &&
            (() => {
              const [x, y] = project(pose.x, pose.y);
              const deg = (-pose.theta * 180) / Math.PI;
              return (
                <g
                  data-testid="robot"
                  data-x={pose.x}
                  data-y={pose.y}
                  data-moving={pose.moving}
                  data-stale={pose.stale || undefined}
                  aria-label={`Robot ${pose.stale ? 'last seen' : 'at'} ${pose.x.toFixed(1)}, ${pose.y.toFixed(1)}${pose.moving && destinationName ? ` driving to ${placeName(destinationName)}` : ''}`}
                  role="img"
                  opacity={pose.stale ? 0.4 : undefined}
                  transform={`translate(${x} ${y}) rotate(${deg})`}
                >
                  <g transform={`scale(${markerScale})`}>
                    <circle r={8} className="fill-robot" />
                    <path d="M 4 -4 L 12 0 L 4 4 Z" className="fill-robot" />
                  </g>
                </g>
              );
            })()}
        </svg>
      )}
      {pose && (
        <p className="px-3 py-1.5 text-xs text-muted">
          {pose.moving
            ? `Driving to ${destinationName ? placeName(destinationName) : 'a goal'}`
            : pose.at_location
              ? `At ${placeNamed(list, pose.at_location)}`
              : 'Stopped'}{' '}
          · click a place to fill “Go to …”
          {floor?.available && floor.blocked.length > 0 && (
            <>
              {' '}
              · <span className="text-map-blocked">■</span> blocked
            </>
          )}
        </p>
      )}
      {pose?.pose_note && (
        // the robot's position is not live, or it jumped when the base came back: said, not hidden
        <p role="status" data-testid="pose-note" className="border-t border-line bg-warn-bg px-3 py-1 text-xs text-fg">
          {pose.stale ? 'Position not live: ' : 'Position jumped: '}
          {pose.pose_note}
        </p>
      )}
      {past && (
        <p className="flex items-center justify-between gap-2 border-t border-line px-3 py-1 text-xs">
          <span className="min-w-0 truncate" title={past.label}>
            <span aria-hidden="true" className="text-history">
              ◆{' '}
            </span>
            {pastPose
              ? `Robot when it saw ${past.label}`
              : past.pose
                ? `${past.label} was seen on map ${past.pose.map}, not this one`
                : `No position recorded for ${past.label}`}
          </span>
          <Button
            variant="ghost"
            aria-label="Clear history marker"
            className="shrink-0 px-2 py-0.5 text-xs"
            onClick={() => clearPast(null)}
          >
            Clear
          </Button>
        </p>
      )}
    </Panel>
  );
}

/** Where the robot stood when it saw a sighting: a dashed ring with its heading in the history
 *  colour, and the label + local time where `label` says (placed around the places' names). */
/** A name on the map, drawn over a halo of the floor colour so lines under it stay legible. */
function MapLabel({
  x,
  y,
  anchor,
  className,
  children,
}: {
  x: number;
  y: number;
  anchor: Anchor;
  className: string;
  children: ReactNode;
}) {
  return (
    <text
      x={x}
      y={y}
      textAnchor={anchor}
      className={`${className} stroke-map-floor text-[10px]`}
      strokeWidth={3}
      style={{ paintOrder: 'stroke' }}
    >
      {children}
    </text>
  );
}

function HistoryMarker({
  sighting,
  pose,
  at,
  label,
}: {
  sighting: Sighting;
  pose: RobotPose;
  at: readonly [number, number];
  label: LabelSpot;
}) {
  const [x, y] = at;
  const [lx, ly, anchor] = label;
  const clock = localClock(sighting.first_seen);
  return (
    <g
      data-testid="history-marker"
      data-x={pose.x}
      data-y={pose.y}
      role="img"
      aria-label={`Robot was here at ${clock} when it saw ${sighting.label}${sighting.place ? ` (${sighting.place})` : ''}`}
    >
      <circle cx={x} cy={y} r={HISTORY_RING - 1} className="fill-none stroke-history" strokeWidth={2.5} strokeDasharray="4 2.5" />
      <polygon
        data-testid="history-heading"
        points={arrowPoints(x, y, pose.yaw, HISTORY_RING)
          .map(([px, py]) => `${px.toFixed(1)},${py.toFixed(1)}`)
          .join(' ')}
        className="fill-history"
      />
      <circle cx={x} cy={y} r={3} className="fill-history" />
      <MapLabel x={lx} y={ly} anchor={anchor} className="fill-history font-semibold">
        {sighting.label} · {clock}
      </MapLabel>
    </g>
  );
}
