import { useCallback, useMemo, useState } from 'react';
import { Panel } from '@/components/ui/Panel';
import { usePolling } from '@/lib/usePolling';
import { useChatStore } from '@/stores/chatStore';
import { fetchLocations, fetchPose, type LocationList, type Pose } from '../api/map';

const POSE_PERIOD_MS = 400; // 2.5 Hz
const WIDTH = 300;
const PAD = 34;

/** Map metres → SVG pixels (y up in the map, down on screen); the height follows the map. */
function projection(list: LocationList, pose: Pose | null) {
  const xs = list.locations.map((l) => l.x).concat(pose ? [pose.x] : []);
  const ys = list.locations.map((l) => l.y).concat(pose ? [pose.y] : []);
  const [minX, maxX, minY, maxY] = [Math.min(...xs), Math.max(...xs), Math.min(...ys), Math.max(...ys)];
  const scale = (WIDTH - 2 * PAD) / Math.max(maxX - minX, maxY - minY, 1);
  const height = Math.min(WIDTH, Math.max(140, 2 * PAD + (maxY - minY) * scale));
  const project = (x: number, y: number) => [PAD + (x - minX) * scale, height - PAD - (y - minY) * scale] as const;
  return { project, height };
}

type Box = { x0: number; y0: number; x1: number; y1: number };
const overlaps = (a: Box, b: Box) => a.x0 < b.x1 && b.x0 < a.x1 && a.y0 < b.y1 && b.y0 < a.y1;

/** Name positions (label baselines) that avoid each other: above, below, right, left. */
export function placeLabels(points: { name: string; cx: number; cy: number }[]): Map<string, [number, number, 'middle' | 'start' | 'end']> {
  const placed: Box[] = points.map((p) => ({ x0: p.cx - 7, y0: p.cy - 7, x1: p.cx + 7, y1: p.cy + 7 }));
  const result = new Map<string, [number, number, 'middle' | 'start' | 'end']>();
  for (const p of points) {
    const w = p.name.length * 5.6;
    const options: [number, number, 'middle' | 'start' | 'end', Box][] = [
      [p.cx, p.cy - 12, 'middle', { x0: p.cx - w / 2, y0: p.cy - 22, x1: p.cx + w / 2, y1: p.cy - 10 }],
      [p.cx, p.cy + 20, 'middle', { x0: p.cx - w / 2, y0: p.cy + 10, x1: p.cx + w / 2, y1: p.cy + 22 }],
      [p.cx + 10, p.cy + 4, 'start', { x0: p.cx + 10, y0: p.cy - 6, x1: p.cx + 10 + w, y1: p.cy + 6 }],
      [p.cx - 10, p.cy + 4, 'end', { x0: p.cx - 10 - w, y0: p.cy - 6, x1: p.cx - 10, y1: p.cy + 6 }],
    ];
    const free = options.find(([, , , box]) => !placed.some((b) => overlaps(b, box))) ?? options[0];
    if (!free) continue;
    placed.push(free[3]);
    result.set(p.name, [free[0], free[1], free[2]]);
  }
  return result;
}

export function MapView() {
  const [list, setList] = useState<LocationList | null>(null);
  const [pose, setPose] = useState<Pose | null>(null);
  const [error, setError] = useState<string | null>(null);
  const setDraft = useChatStore((s) => s.setDraft);

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

  const view = useMemo(() => (list ? projection(list, pose) : null), [list, pose]);
  const project = view?.project ?? null;
  const labels = useMemo(
    () =>
      list && view
        ? placeLabels(list.locations.map((l) => ({ name: l.name, cx: view.project(l.x, l.y)[0], cy: view.project(l.x, l.y)[1] })))
        : new Map<string, [number, number, 'middle' | 'start' | 'end']>(),
    [list, view],
  );
  const destination = pose?.destination ?? null;

  return (
    <Panel label="Map" title={list ? `Map — ${list.map}` : 'Map'}>
      {!list || !project ? (
        <p className="p-3 text-sm text-muted">{error ? `Navigation unavailable: ${error}` : 'Loading the map…'}</p>
      ) : (
        <svg viewBox={`0 0 ${WIDTH} ${view?.height ?? WIDTH}`} className="block w-full bg-map-floor lg:max-h-[38vh]" role="group" aria-label="Floor map">
          {list.locations.map((loc) => {
            const [cx, cy] = project(loc.x, loc.y);
            const [lx, ly, anchor] = labels.get(loc.name) ?? [cx, cy - 12, 'middle'];
            const isDestination = loc.name === destination;
            return (
              <g
                key={loc.name}
                role="button"
                tabIndex={0}
                aria-label={`Go to ${loc.name}`}
                data-destination={isDestination || undefined}
                className="cursor-pointer focus-visible:outline-2 focus-visible:outline-accent"
                onClick={() => setDraft(`Go to ${loc.name}`)}
                onKeyDown={(e) => {
                  if (e.key === 'Enter' || e.key === ' ') {
                    e.preventDefault();
                    setDraft(`Go to ${loc.name}`);
                  }
                }}
              >
                <title>{loc.description || loc.name}</title>
                {/* A generous, invisible tap target covering the dot and its name. */}
                <rect x={cx - 34} y={cy - 26} width={68} height={38} fill="transparent" />
                <circle
                  cx={cx}
                  cy={cy}
                  r={isDestination ? 9 : 6}
                  className={isDestination ? 'fill-accent stroke-accent' : 'fill-surface stroke-muted'}
                  strokeWidth={2}
                />
                <text x={lx} y={ly} textAnchor={anchor} className="fill-fg text-[10px]">
                  {loc.name}
                </text>
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
                  aria-label={`Robot at ${pose.x.toFixed(1)}, ${pose.y.toFixed(1)}${pose.moving ? ` driving to ${pose.destination}` : ''}`}
                  role="img"
                  transform={`translate(${x} ${y}) rotate(${deg})`}
                >
                  <circle r={8} className="fill-robot" />
                  <path d="M 4 -4 L 12 0 L 4 4 Z" className="fill-robot" />
                </g>
              );
            })()}
        </svg>
      )}
      {pose && (
        <p className="px-3 py-1.5 text-xs text-muted">
          {pose.moving ? `Driving to ${pose.destination}` : pose.at_location ? `At ${pose.at_location}` : 'Stopped'} ·
          click a place to fill “Go to …”
        </p>
      )}
    </Panel>
  );
}
