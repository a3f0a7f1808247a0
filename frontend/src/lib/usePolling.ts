import { useEffect, useRef } from 'react';

/** Run `tick` every `periodMs` while the page is visible (and `enabled`); one tick at a time.
 *  A new `restartKey` (e.g. the window a panel shows) runs a tick at once and restarts the period. */
export function usePolling(tick: () => Promise<void>, periodMs: number, enabled = true, restartKey?: unknown): void {
  const saved = useRef(tick);
  useEffect(() => {
    saved.current = tick;
  }, [tick]);
  useEffect(() => {
    if (!enabled) return;
    let stopped = false;
    let timer: ReturnType<typeof setTimeout> | undefined;
    const run = async () => {
      if (stopped) return;
      if (document.visibilityState === 'visible') {
        try {
          await saved.current();
        } catch {
          /* the tick shows its own error state */
        }
      }
      if (!stopped) timer = setTimeout(run, periodMs);
    };
    void run();
    return () => {
      stopped = true;
      clearTimeout(timer);
    };
  }, [periodMs, enabled, restartKey]);
}
