import { useEffect } from 'react';
import { Toasts } from '@/components/ui/Toasts';
import { CameraView } from '@/features/camera/components/CameraView';
import { Conversation, LiveAnnouncer } from '@/features/chat/components/Conversation';
import { MessageBox } from '@/features/chat/components/MessageBox';
import { HistoryPanel } from '@/features/history/components/HistoryPanel';
import { MapView } from '@/features/map/components/MapView';
import { MissionPanel } from '@/features/mission/components/MissionPanel';
import { SafetyBanner } from '@/features/safety/components/SafetyBanner';
import { StatusBar } from '@/features/status/components/StatusBar';
import { useSettingsStore } from '@/stores/settingsStore';
import { Header as AppHeader } from './Header';
import { useBoot } from './useBoot';

export function App() {
  const theme = useSettingsStore((s) => s.theme);
  useEffect(() => {
    document.documentElement.dataset.theme = theme;
  }, [theme]);
  useBoot();
  return (
    <div className="flex h-full flex-col">
      <AppHeader />
      <SafetyBanner />
      <main className="grid min-h-0 flex-1 grid-cols-1 gap-3 overflow-y-auto p-3 lg:grid-cols-[minmax(0,1fr)_380px] lg:overflow-hidden">
        <div className="flex min-h-[40vh] flex-col gap-3 lg:min-h-0">
          <div className="max-h-[55%] shrink-0 overflow-y-auto">
            <MissionPanel />
          </div>
          <section aria-label="Chat" className="flex min-h-0 flex-1 flex-col rounded-lg border border-line bg-surface">
            <Conversation />
            <MessageBox />
          </section>
        </div>
        {/* The map first: the whole of it stays in view above the status bar at 1280×800 and,
            below the chat, at 768 px wide (issue 39); the camera follows it. */}
        <aside className="grid grid-cols-1 content-start gap-3 md:grid-cols-2 lg:grid-cols-1 lg:overflow-y-auto">
          <MapView />
          <CameraView />
          <HistoryPanel />
        </aside>
      </main>
      <StatusBar />
      <Toasts />
      <LiveAnnouncer />
    </div>
  );
}
