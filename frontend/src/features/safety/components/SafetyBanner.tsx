import { useState } from 'react';
import { Button } from '@/components/ui/Button';
import { useSafetyStore } from '@/stores/safetyStore';
import { useToastStore } from '@/stores/toastStore';
import type { SafetyAlarm } from '@/types/events';
import { clearStop } from '../api/safety';
import { HARDWARE_ESTOP_NOTE } from './StopRobot';

function clock(epochS: number | null | undefined): string {
  return epochS ? new Date(epochS * 1000).toLocaleTimeString() : 'earlier';
}

/** What each supervision alarm means, for the operator (the codes stay in logs and the API). */
const ALARM_TITLES: Record<string, string> = {
  FOREIGN_HOLDER: 'Another program renewed the safety lease',
  LOCK_TOPIC_SHARED: 'Another program publishes on the motion lock',
  POSE_TOPIC_SHARED: "Another program publishes the robot's position",
  MAP_TOPIC_SHARED: 'Another program publishes the map',
  FOREIGN_GOAL_CLIENT: 'Another program sent the base a drive goal',
};
const PARTS: Record<string, string> = { navigation: 'base', manipulation: 'arm' };

function alarmTitle(alarm: SafetyAlarm): string {
  return ALARM_TITLES[alarm.code] ?? 'Safety alarm';
}

/** The supervision alarms the motion servers report now, one line each. */
function Alarms({ alarms }: { alarms: SafetyAlarm[] }) {
  return (
    <ul aria-label="Supervision alarms" className="w-full list-disc pl-6">
      {alarms.map((alarm) => (
        <li key={`${alarm.server}-${alarm.code}-${alarm.at ?? 0}`}>
          <strong>{alarmTitle(alarm)}</strong> ({PARTS[alarm.server] ?? alarm.server}, since {clock(alarm.at)})
          {alarm.detail ? `: ${alarm.detail}` : ''}
        </li>
      ))}
    </ul>
  );
}

/** While the software stop is latched (or a supervision alarm is active): who/when/why, the
 * alarms by name, and Clear stop behind a confirmation. */
export function SafetyBanner() {
  const latch = useSafetyStore((s) => s.latch);
  const [confirming, setConfirming] = useState(false);
  const [reason, setReason] = useState('');
  const [busy, setBusy] = useState(false);
  const alarms = latch?.alarms ?? [];
  if (!latch?.latched && alarms.length === 0) return null;

  const confirm = async () => {
    setBusy(true);
    try {
      useSafetyStore.getState().setLatch(await clearStop(reason.trim()));
      setConfirming(false);
      setReason('');
      useToastStore.getState().push('info', 'Stop cleared. Nothing resumes by itself: give the robot a new instruction.');
    } catch (err: unknown) {
      useToastStore.getState().push('error', `Clear stop failed: ${String(err)}`);
    } finally {
      setBusy(false);
    }
  };

  return (
    <section
      aria-label="Safety stop"
      className="flex flex-wrap items-center gap-2 border-b border-line bg-danger px-3 py-2 text-sm text-danger-fg"
    >
      {latch?.latched ? (
        <p className="mr-auto" role="alert">
          <strong>Software stop latched</strong> since {clock(latch.since)} by {latch.by ?? 'unknown'}: {latch.reason}.
          The robot will not move until an operator clears it.{' '}
          <span className="opacity-90">{HARDWARE_ESTOP_NOTE}</span>
        </p>
      ) : (
        <p className="mr-auto" role="alert">
          <strong>Supervision alarm</strong>: the robot refuses to move while it lasts.
        </p>
      )}
      {alarms.length > 0 && <Alarms alarms={alarms} />}
      {!latch?.latched ? null : !confirming ? (
        <Button variant="secondary" onClick={() => setConfirming(true)}>
          Clear stop
        </Button>
      ) : (
        <form
          className="flex flex-wrap items-center gap-2"
          onSubmit={(e) => {
            e.preventDefault();
            void confirm();
          }}
        >
          <label className="flex items-center gap-1">
            Why is it safe to move?
            <input
              className="w-80 max-w-full rounded-md border border-line bg-surface px-2 py-1 text-fg"
              value={reason}
              onChange={(e) => setReason(e.target.value)}
              minLength={3}
              maxLength={200}
              required
              autoFocus
            />
          </label>
          <Button type="submit" variant="secondary" disabled={busy || reason.trim().length < 3}>
            Confirm clear stop
          </Button>
          <Button variant="ghost" className="text-danger-fg" onClick={() => setConfirming(false)}>
            Cancel
          </Button>
        </form>
      )}
    </section>
  );
}
