import { apiGet, apiPost } from '@/lib/api-client';
import { emitWithAck, getSocket } from '@/lib/socket';
import type { FeedItem } from '@/stores/chatStore';

/** Send a turn over Socket.IO (REST when the socket is down). */
export async function sendMessage(text: string): Promise<void> {
  if (getSocket().connected) {
    const reply = await emitWithAck('send_message', { text });
    if (!reply.ok) throw new Error(reply.error ?? 'the robot refused the message');
    return;
  }
  await apiPost('/api/chat', { text });
}

interface HistoryLine {
  event: string;
  turn_id?: string;
  role?: 'user' | 'assistant';
  text?: string;
  message?: string;
  mission_id?: string;
  outcome?: string;
  summary?: string;
  /** mission_finished: the mission's human title, served with the line (issue 39) */
  instruction?: string;
}

export async function fetchHistory(): Promise<FeedItem[]> {
  const { lines } = await apiGet<{ lines: HistoryLine[] }>('/api/chat/history?limit=50');
  return lines.flatMap((line, i): FeedItem[] => {
    const key = `h${i}`;
    if (line.event === 'chat_message' && line.role && line.text !== undefined)
      return [{ kind: 'message', key, turnId: line.turn_id ?? key, role: line.role, text: line.text }];
    if (line.event === 'chat_error')
      return [{ kind: 'error', key, turnId: line.turn_id ?? key, text: line.message ?? '' }];
    if (line.event === 'mission_finished')
      return [
        {
          kind: 'summary',
          key,
          missionId: line.mission_id ?? key,
          instruction: line.instruction ?? '',
          outcome: line.outcome ?? '',
          summary: line.summary ?? '',
          steps: [],
        },
      ];
    return [];
  });
}
