import { useCallback, useEffect, useRef, useState } from 'react';
import { Panel } from '@/components/ui/Panel';
import { usePolling } from '@/lib/usePolling';
import { fetchDetections, fetchFrame, type Detections } from '../api/camera';

const FRAME_PERIOD_MS = 350; // ≈ 3 fps while visible
const DETECTIONS_PERIOD_MS = 1000;

function useVisible(ref: React.RefObject<HTMLElement | null>): boolean {
  const [visible, setVisible] = useState(true);
  useEffect(() => {
    const el = ref.current;
    if (!el || typeof IntersectionObserver === 'undefined') return;
    const observer = new IntersectionObserver(([entry]) => setVisible(entry?.isIntersecting ?? true));
    observer.observe(el);
    return () => observer.disconnect();
  }, [ref]);
  return visible;
}

export function CameraView() {
  const box = useRef<HTMLDivElement>(null);
  const visible = useVisible(box);
  const [src, setSrc] = useState<string | null>(null);
  const [offline, setOffline] = useState<string | null>(null);
  const [detections, setDetections] = useState<Detections | null>(null);

  const tickFrame = useCallback(async () => {
    try {
      const blob = await fetchFrame();
      const url = URL.createObjectURL(blob);
      setSrc((old) => {
        if (old) URL.revokeObjectURL(old);
        return url;
      });
      setOffline(null);
    } catch (err) {
      setOffline(err instanceof Error ? err.message : String(err));
    }
  }, []);
  const tickDetections = useCallback(async () => {
    try {
      setDetections(await fetchDetections());
    } catch {
      setDetections(null);
    }
  }, []);
  usePolling(tickFrame, FRAME_PERIOD_MS, visible);
  usePolling(tickDetections, DETECTIONS_PERIOD_MS, visible);

  return (
    <Panel label="Camera view" title="Camera">
      <div ref={box} className="aspect-[4/3] bg-raised lg:aspect-auto lg:h-[30vh]">
        {offline || !src ? (
          <div role="img" aria-label="Camera" className="flex h-full flex-col items-center justify-center p-4 text-center">
            <strong className="text-sm">{offline ? 'Camera offline' : 'Waiting for the camera…'}</strong>
            {offline && <span className="mt-1 text-xs text-muted">{offline}</span>}
          </div>
        ) : (
          <img alt="Camera" src={src} className="h-full w-full object-contain" data-live="true" />
        )}
      </div>
      <div className="px-3 py-2">
        {detections?.scene && (
          <p className="mb-2 text-sm" aria-label="Scene description">
            <span className="text-xs font-semibold text-muted">Scene </span>
            {detections.scene}
            {detections.scene_age_s != null && detections.scene_age_s >= 2 && (
              <span className="text-xs text-muted"> · {Math.round(detections.scene_age_s)} s ago</span>
            )}
          </p>
        )}
        <h3 className="text-xs font-semibold text-muted">Detections</h3>
        {detections && detections.detections.length > 0 ? (
          <table className="mt-1 w-full text-xs">
            <thead className="text-left text-muted">
              <tr>
                <th className="font-normal">label</th>
                <th className="font-normal">score</th>
                <th className="font-normal">skill</th>
                <th className="font-normal">age</th>
              </tr>
            </thead>
            <tbody>
              {detections.detections.slice(0, 8).map((d, i) => (
                <tr key={`${d.skill}-${d.label}-${i}`} className={d.stale ? 'text-muted' : ''}>
                  <td>{d.label}</td>
                  <td>{d.score === null ? '–' : d.score.toFixed(2)}</td>
                  <td className="font-mono">{d.skill}</td>
                  <td>{d.age_s === null ? '–' : `${d.age_s.toFixed(1)} s`}</td>
                </tr>
              ))}
            </tbody>
          </table>
        ) : (
          <p className="mt-1 text-xs text-muted">{detections ? 'Nothing detected right now.' : 'Perception unavailable.'}</p>
        )}
      </div>
    </Panel>
  );
}
