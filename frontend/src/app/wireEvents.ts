import { silence, speak } from '@/features/voice/speech';
import type { RobotSocket } from '@/lib/socket';
import { useChatStore } from '@/stores/chatStore';
import { useConnectionStore } from '@/stores/connectionStore';
import { useApprovalStore } from '@/stores/approvalStore';
import { useMissionStore } from '@/stores/missionStore';
import { useSafetyStore } from '@/stores/safetyStore';
import { useSettingsStore } from '@/stores/settingsStore';
import { useToastStore } from '@/stores/toastStore';
import type { MissionPlanPayload } from '@/types/events';

/**
 * mission_plan snapshots are full states, so only the newest one per animation frame needs
 * rendering (a burst of hundreds per second costs one render per frame, never a lost final
 * state). Every other mission event first flushes the pending snapshot to keep the order.
 */
function planCoalescer(apply: (snapshot: MissionPlanPayload) => void) {
  let pending: MissionPlanPayload | null = null;
  let scheduled = false;
  const flush = () => {
    scheduled = false;
    if (pending) {
      const latest = pending;
      pending = null;
      apply(latest);
    }
  };
  const push = (snapshot: MissionPlanPayload) => {
    pending = snapshot;
    if (scheduled) return;
    scheduled = true;
    if (document.visibilityState === 'visible') requestAnimationFrame(flush);
    else setTimeout(flush, 100);
  };
  return { push, flush };
}

/** Socket.IO events → stores (the only place server state enters the UI). */
export function wireEvents(socket: RobotSocket, onReconnect: () => void): () => void {
  const connection = useConnectionStore.getState();
  const chat = () => useChatStore.getState();
  const missions = () => useMissionStore.getState();
  const toast = (tone: 'info' | 'success' | 'error', text: string) =>
    useToastStore.getState().push(tone, text);

  socket.on('connect', () => {
    const wasDown = useConnectionStore.getState().attempts > 0;
    connection.setState('connected', 0);
    if (wasDown) onReconnect();
  });
  socket.on('disconnect', () => connection.setState('reconnecting'));
  socket.io.on('reconnect_attempt', (attempt) => connection.setState('reconnecting', attempt));
  socket.io.on('reconnect_failed', () => connection.setState('disconnected'));

  socket.on('chat_delta', (e) => chat().delta(e.turn_id, e.text));
  socket.on('chat_message', (e) => chat().message(e.turn_id, e.role, e.text));
  socket.on('chat_error', (e) => chat().error(e.turn_id, e.message));
  const plans = planCoalescer((e) => missions().applySnapshot(e));
  socket.on('mission_started', (e) => {
    plans.flush();
    missions().started(e);
  });
  socket.on('mission_plan', (e) => plans.push(e));
  socket.on('mission_event', (e) => {
    plans.flush();
    missions().addEvent(e);
  });
  socket.on('mission_finished', (e) => {
    plans.flush();
    const mission = missions().mission;
    missions().finished(e);
    chat().summary({
      missionId: e.mission_id,
      instruction: mission?.id === e.mission_id ? mission.instruction : '',
      outcome: e.outcome,
      summary: e.summary,
      steps: mission?.id === e.mission_id ? mission.steps : [],
      usage: e.usage ?? undefined,
    });
  });
  socket.on('teaching_state', (e) => useSettingsStore.getState().setTeaching(e.armed));
  socket.on('teaching_saved', (e) => toast('success', `Process saved: ${e.process_id}`));
  socket.on('teaching_failed', (e) => toast('error', `Teaching failed: ${e.reason}`));
  socket.on('safety_state', (e) => useSafetyStore.getState().setLatch(e));
  socket.on('approval_requested', (e) => useApprovalStore.getState().requested(e));
  socket.on('approval_resolved', (e) => {
    useApprovalStore.getState().resolved(e.approval_id);
    if (e.decision === 'deny') toast('info', `Denied: ${e.reason || 'by the operator'}`);
  });
  socket.on('speak', (e) => speak(e.text));
  socket.on('speech_interrupted', () => silence());
  socket.connect();
  return () => {
    socket.removeAllListeners();
    socket.io.removeAllListeners();
    socket.disconnect();
  };
}
