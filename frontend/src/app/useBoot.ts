import { useEffect } from 'react';
import { fetchHistory } from '@/features/chat/api/chat';
import { fetchActiveMission, traceLine } from '@/features/mission/api/missions';
import { fetchApprovals } from '@/features/approvals/api/approvals';
import { getSafety } from '@/features/safety/api/safety';
import { fetchUiConfig } from '@/features/status/api/status';
import { getTeaching } from '@/features/teaching/api/teaching';
import { getSocket } from '@/lib/socket';
import { useChatStore } from '@/stores/chatStore';
import { useApprovalStore } from '@/stores/approvalStore';
import { useMissionStore } from '@/stores/missionStore';
import { useSafetyStore } from '@/stores/safetyStore';
import { useSettingsStore } from '@/stores/settingsStore';
import { wireEvents } from './wireEvents';

/** After a (re)load or reconnect: the active mission as the brain holds it (spec §11.2). */
export async function rehydrateMission(): Promise<void> {
  void fetchApprovals().then(useApprovalStore.getState().load, () => undefined);
  const detail = await fetchActiveMission();
  if (detail) useMissionStore.getState().rehydrate(detail, detail.events.map(traceLine));
}

export function useBoot(): void {
  useEffect(() => {
    const unwire = wireEvents(getSocket(), () => void rehydrateMission().catch(() => undefined));
    void fetchUiConfig().then(useSettingsStore.getState().setConfig, () => undefined);
    void getTeaching().then(useSettingsStore.getState().setTeaching, () => undefined);
    void fetchHistory().then(useChatStore.getState().load, () => undefined);
    void rehydrateMission().catch(() => undefined);
    void getSafety().then(useSafetyStore.getState().setLatch, () => undefined);
    return unwire;
  }, []);
}
