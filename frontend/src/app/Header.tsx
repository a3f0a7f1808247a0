import { Button } from '@/components/ui/Button';
import { Icon } from '@/components/ui/Icon';
import { StopRobot } from '@/features/safety/components/StopRobot';
import { TeachButton } from '@/features/teaching/components/TeachButton';
import { silence } from '@/features/voice/speech';
import { useSettingsStore } from '@/stores/settingsStore';

export function Header() {
  const { theme, setTheme, muted, setMuted, config } = useSettingsStore();
  const next = theme === 'dark' ? 'light' : 'dark';
  return (
    <header className="flex flex-wrap items-center gap-2 border-b border-line bg-surface px-3 py-2">
      <h1 className="mr-auto text-base font-semibold">Robot operator</h1>
      <TeachButton />
      {config?.speech_output_browser && (
        <Button
          variant="ghost"
          aria-pressed={muted}
          onClick={() => {
            if (!muted) silence();
            setMuted(!muted);
          }}
        >
          <Icon name={muted ? 'muted' : 'speaker'} />
          {muted ? 'Unmute' : 'Mute'}
        </Button>
      )}
      <Button variant="ghost" aria-label={`Switch to ${next} theme`} onClick={() => setTheme(next)}>
        <Icon name={theme === 'dark' ? 'sun' : 'moon'} />
      </Button>
      <StopRobot />
    </header>
  );
}
