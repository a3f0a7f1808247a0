import { useCallback, useEffect } from 'react';
import { Icon } from '@/components/ui/Icon';
import { Button } from '@/components/ui/Button';
import { stopPipeline } from '@/features/mission/api/missions';
import { silence } from '@/features/voice/speech';
import { useToastStore } from '@/stores/toastStore';

/** Always visible; Esc anywhere: stop_pipeline (motion cancelled, vision skills stopped). */
export function EmergencyStop() {
  const stop = useCallback(() => {
    silence();
    stopPipeline().then(
      () => useToastStore.getState().push('info', 'Emergency stop sent: the brain cancels motion and stops vision skills.'),
      (err: unknown) => useToastStore.getState().push('error', `Emergency stop failed: ${String(err)}`),
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
    <Button variant="danger" onClick={stop} aria-keyshortcuts="Escape" title="Emergency stop (Esc)" className="font-bold">
      <Icon name="stop" />
      Emergency stop
    </Button>
  );
}
