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
  const destination = pose?.destination ?? null;

  return (
    <Panel label="Map" title={list ? `Map — ${list.map}` : 'Map'}>
      {!list || !project ? (
        <p className="p-3 text-sm text-muted">{error ? `Navigation unavailable: ${error}` : 'Loading the map…'}</p>
      ) : (
        <svg viewBox={`0 0 ${WIDTH} ${view?.height ?? WIDTH}`} className="block w-full bg-map-floor" role="group" aria-label="Floor map">
          {list.locations.map((loc, index) => {
            const [cx, cy] = project(loc.x, loc.y);
            const below = index % 2 === 1; // neighbours' names alternate above/below their dots
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
                <text x={cx} y={below ? cy + 20 : cy - 12} textAnchor="middle" className="fill-fg text-[10px]">
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
