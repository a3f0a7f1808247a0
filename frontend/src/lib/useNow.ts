import { useEffect, useState } from 'react';

/** Seconds since the epoch, refreshed every `periodMs` while `active`. */
export function useNow(active: boolean, periodMs = 1000): number {
  const [now, setNow] = useState(() => Date.now() / 1000);
  useEffect(() => {
    if (!active) return;
    const timer = setInterval(() => setNow(Date.now() / 1000), periodMs);
    return () => clearInterval(timer);
  }, [active, periodMs]);
  return now;
}

export function formatElapsed(seconds: number): string {
  const s = Math.max(0, Math.floor(seconds));
  const m = Math.floor(s / 60);
  return `${m}:${String(s % 60).padStart(2, '0')}`;
}
