import { useEffect, useRef } from 'react';

/** Run `tick` every `periodMs` while the page is visible (and `enabled`); one tick at a time. */
export function usePolling(tick: () => Promise<void>, periodMs: number, enabled = true): void {
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
  }, [periodMs, enabled]);
}
