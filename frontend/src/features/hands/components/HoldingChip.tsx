import { useCallback, useState } from 'react';
import { usePolling } from '@/lib/usePolling';
import { fetchHeld, type Held } from '../api/held';

const ACTION: Record<string, string> = { pick: 'picking up', place: 'putting down', release: 'letting go' };

/** The status bar's chip for the robot's gripper: what it holds (read back from the arm's
 *  server, never assumed), what the arm is doing, or that no arm is connected. */
export function HoldingChip({ periodMs = 2000 }: { periodMs?: number }) {
  const [held, setHeld] = useState<Held | null>(null);
  const [noArm, setNoArm] = useState(false);
  const tick = useCallback(async () => {
    try {
      setHeld(await fetchHeld());
      setNoArm(false);
    } catch {
      setNoArm(true);
    }
  }, []);
  usePolling(tick, periodMs);

  if (noArm) {
    return (
      <span data-testid="holding" data-holding="" className="text-muted" title="No manipulation server connected">
        Arm: <strong>not connected</strong>
      </span>
    );
  }
  if (!held) return null;
  const label = held.holding && held.label ? held.label : '';
  const doing = held.busy && held.action ? ACTION[held.action] : null;
  const text = !held.known ? 'unknown' : label ? label : 'empty';
  return (
    <span
      data-testid="holding"
      data-holding={label}
      className={`flex items-center gap-1 rounded-full border px-2 ${
        label ? 'border-status-running text-fg' : 'border-line text-muted'
      }`}
      aria-label={label ? `Holding ${label}` : `Gripper ${text}`}
    >
      <span aria-hidden="true" className={`h-2 w-2 rounded-full ${label ? 'bg-status-running' : 'bg-line'}`} />
      {label ? 'Holding' : 'Gripper'}: <strong>{text}</strong>
      {doing && <span className="text-status-running"> · {doing}</span>}
    </span>
  );
}
