import { useCallback, useEffect } from 'react';
import { Icon } from '@/components/ui/Icon';
import { Button } from '@/components/ui/Button';
import { stopPipeline } from '@/features/mission/api/missions';
import { silence } from '@/features/voice/speech';
import { useToastStore } from '@/stores/toastStore';

export const HARDWARE_ESTOP_NOTE =
  'Stop robot is a software stop request through the robot’s own controller, not an emergency stop. ' +
  'The robot’s hardware emergency stop remains required (IEC 60204-1 / ISO 13850).';

/** Always visible; Esc anywhere: the software stop (motion cancelled, vision skills stopped),
 * latched until an operator presses Clear stop. */
export function StopRobot() {
  const stop = useCallback(() => {
    silence();
    stopPipeline().then(
      () => useToastStore.getState().push('info', 'Stop sent: motion cancelled; the stop stays latched until Clear stop.'),
      (err: unknown) => useToastStore.getState().push('error', `Stop robot failed: ${String(err)}`),
    );
  }, []);
  useEffect(() => {
    const onKey = (e: KeyboardEvent) => {
      if (e.key === 'Escape') {
        e.preventDefault();
        stop();
      }
    };
    window.addEventListener('keydown', onKey);
    return () => window.removeEventListener('keydown', onKey);
  }, [stop]);
  return (
    <Button
      variant="danger"
      onClick={stop}
      aria-keyshortcuts="Escape"
      title={`Stop robot (Esc). ${HARDWARE_ESTOP_NOTE}`}
      className="font-bold"
    >
      <Icon name="stop" />
      Stop robot
    </Button>
  );
}
