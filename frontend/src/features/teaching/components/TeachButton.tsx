import { Button } from '@/components/ui/Button';
import { useSettingsStore } from '@/stores/settingsStore';
import { useToastStore } from '@/stores/toastStore';
import { setTeaching } from '../api/teaching';

/** Arms teaching for the next mission (POST /api/agent/teaching); the pill shows it is armed. */
export function TeachButton() {
  const armed = useSettingsStore((s) => s.teachingArmed);
  const setArmed = useSettingsStore((s) => s.setTeaching);
  const toggle = () =>
    setTeaching(!armed).then(setArmed, (err: unknown) =>
      useToastStore.getState().push('error', `Teaching: ${String(err)}`),
    );
  return (
    <div className="flex items-center gap-2">
      <Button aria-pressed={armed} onClick={() => void toggle()}>
        Teach
      </Button>
      {armed && (
        <span role="status" className="rounded-full border border-accent px-2 py-0.5 text-xs font-semibold text-accent">
          Teaching next mission
        </span>
      )}
    </div>
  );
}
